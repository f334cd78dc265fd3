"""Independent (non-shared) policies for SB3's actor-critic algorithms (``--independent``).

One SB3 model holds ``A`` complete actor-critic policies (*members*, ``A = len(possible_agents)``),
one per robot: member ``i`` has its own networks (actor, critic, ``log_std``), initialised
separately, and acts for robot ``i`` only. Each batch row is routed to its robot's member by the
robot-index one-hot in its observation (:class:`~baselines.rl.agent_features.ObservationFeatures`,
``agent_id=True``; a padding row, all zeros, goes to member 0), so the parameters of member ``i`` are
fitted on robot ``i``'s transitions alone: no parameter is shared. What the members share is the
algorithm around them: one rollout of the team, one optimiser over all parameters (Adam's moments
are per parameter, so this is ``A`` optimisers in one), one mini-batch advantage normalisation and
one gradient-norm clip (``max_grad_norm``) over all members.

Stored as one ordinary SB3 zip: the policy class (:class:`IndependentPolicy` or
:class:`MaskableIndependentPolicy`), its ``policy_kwargs`` (``n_agents``, ``id_start``,
``actor_dim``) and the state dict whose keys ``members.<i>.*`` are robot ``i``'s networks.
``PPO.load``/``MaskablePPO.load`` (and ``sb3:PATH``) load every member at once;
:func:`member` gives robot ``i``'s policy alone. With ``actor_dim`` set, each member is a
centralised-critic policy (:mod:`baselines.rl.central_critic`): ``--independent --critic central``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticPolicy
from torch import nn

from baselines.rl.central_critic import CentralCriticPolicy

__all__ = ["IndependentPolicy", "MaskableIndependentPolicy", "independent_policy_class", "member"]


def _take(values: Any, rows: th.Tensor) -> Any:
    if values is None:
        return None
    if isinstance(values, th.Tensor):
        return values[rows.to(values.device)]
    return np.asarray(values)[rows.cpu().numpy()]


class _Routed:
    """Mixin of an actor-critic policy: ``n_agents`` member policies, rows routed by the one-hot at ``id_start``."""

    plain_member: type
    central_member: type

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        lr_schedule: Any,
        *,
        n_agents: int,
        id_start: int,
        actor_dim: int | None = None,
        **kwargs: Any,
    ) -> None:
        width = int(np.prod(observation_space.shape))
        if n_agents < 1 or not 0 <= id_start <= width - n_agents:
            raise ValueError(f"need n_agents >= 1 and the one-hot inside the {width} inputs, got {n_agents} at {id_start}")
        self.n_agents, self.id_start, self.member_actor_dim = int(n_agents), int(id_start), actor_dim
        self._member_kwargs = dict(kwargs)
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def _build(self, lr_schedule: Any) -> None:
        """Build the members (each with its own initialisation) and one optimiser over all of them."""
        cls = self.plain_member if self.member_actor_dim is None else self.central_member
        extra = {} if self.member_actor_dim is None else {"actor_dim": self.member_actor_dim}
        self.members = nn.ModuleList(
            cls(self.observation_space, self.action_space, lr_schedule, **self._member_kwargs, **extra)
            for _ in range(self.n_agents)
        )
        for one in self.members:
            one.optimizer = None  # the members are fitted by this policy's optimiser
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        extra = {"n_agents": self.n_agents, "id_start": self.id_start, "actor_dim": self.member_actor_dim}
        return {**super()._get_constructor_parameters(), **extra}

    def robot_index(self, obs: th.Tensor) -> th.Tensor:
        """The robot index of every row (the argmax of its one-hot; 0 for an all-zero padding row)."""
        flat = obs.reshape(obs.shape[0], -1)
        return flat[:, self.id_start : self.id_start + self.n_agents].argmax(dim=1)

    def _route(self, method: str, obs: th.Tensor, *rowwise: Any, action_masks: Any = None, **static: Any) -> Any:
        """``members[i].method`` on the rows of robot ``i``, results put back in row order."""
        index = self.robot_index(obs)
        outputs: list[Any] | None = None
        single = False
        for i in range(self.n_agents):
            rows = th.nonzero(index == i, as_tuple=True)[0]
            if len(rows) == 0:
                continue
            kwargs = dict(static)
            if action_masks is not None:
                kwargs["action_masks"] = _take(action_masks, rows)
            result = getattr(self.members[i], method)(obs[rows], *(_take(v, rows) for v in rowwise), **kwargs)
            single = not isinstance(result, tuple)
            parts = (result,) if single else result
            if outputs is None:
                outputs = [None if p is None else p.new_zeros((obs.shape[0], *p.shape[1:])) for p in parts]
            for out, part in zip(outputs, parts):
                if out is not None:
                    out[rows] = part
        assert outputs is not None, "an empty batch"
        return outputs[0] if single else tuple(outputs)

    def forward(self, obs: th.Tensor, deterministic: bool = False, action_masks: Any = None) -> Any:
        return self._route("forward", obs, deterministic=deterministic, action_masks=action_masks)

    def evaluate_actions(self, obs: th.Tensor, actions: th.Tensor, action_masks: Any = None) -> Any:
        return self._route("evaluate_actions", obs, actions, action_masks=action_masks)

    def predict_values(self, obs: th.Tensor) -> th.Tensor:
        return self._route("predict_values", obs)

    def _predict(self, observation: th.Tensor, deterministic: bool = False, action_masks: Any = None) -> th.Tensor:
        return self._route("_predict", observation, deterministic=deterministic, action_masks=action_masks)

    def get_distribution(self, obs: th.Tensor, action_masks: Any = None) -> Any:
        raise NotImplementedError("an independent policy has one distribution per robot: use member(policy, i)")


class IndependentPolicy(_Routed, ActorCriticPolicy):
    """PPO/A2C policy of ``n_agents`` non-shared :class:`ActorCriticPolicy` members (see the module docstring)."""

    plain_member = ActorCriticPolicy
    central_member = CentralCriticPolicy


try:
    from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy

    from baselines.rl.central_critic import MaskableCentralCriticPolicy
except ImportError:  # sb3-contrib is optional
    pass
else:

    class MaskableIndependentPolicy(_Routed, MaskableActorCriticPolicy):
        """MaskablePPO policy of ``n_agents`` non-shared maskable members (see the module docstring)."""

        plain_member = MaskableActorCriticPolicy
        central_member = MaskableCentralCriticPolicy


def independent_policy_class(algo: str) -> type:
    """The independent-policies class of ``algo`` (``ppo``, ``a2c`` or ``maskable_ppo``)."""
    if algo == "maskable_ppo":
        return MaskableIndependentPolicy
    if algo in ("ppo", "a2c"):
        return IndependentPolicy
    raise ValueError(f"--independent needs an actor-critic algorithm (ppo, a2c, maskable_ppo), not {algo}")


def member(policy: Any, i: int) -> Any:
    """Robot ``i``'s own policy inside an independent model's ``policy`` (an SB3 actor-critic policy)."""
    if not isinstance(policy, _Routed):
        raise TypeError(f"not an independent policy: {type(policy).__name__}")
    if not 0 <= i < policy.n_agents:
        raise ValueError(f"robot index must be in [0, {policy.n_agents}), got {i}")
    return policy.members[i]
