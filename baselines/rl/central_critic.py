"""A centralised critic for SB3's actor-critic algorithms (MAPPO-style: ``--critic central``).

The observation a robot's slot reports is ``[own observation | one-hot (with --agent-id) | team state]``
(:class:`~baselines.rl.agent_features.ObservationFeatures`, ``team_state=True``). The policies here
split it inside the network: the **actor** (``mlp_extractor.policy_net``) reads only the first
``actor_dim`` entries (the robot's own observation and its one-hot), the **critic**
(``mlp_extractor.value_net``) reads all of it, the team ``state()`` included. So the value
``V(o_i, s)`` is centralised while the policy ``π(a | o_i)`` stays decentralised, as in MAPPO
(Yu et al., 2022, "The Surprising Effectiveness of PPO in Cooperative Multi-Agent Games": the
critic takes the global state, the actor the local observation). Training (PPO/A2C/MaskablePPO's
own losses) is unchanged; the state entries have no effect on the action distribution, so at
evaluation the actor needs only the robot's own input (the loader still passes the real state,
which the actor ignores).

* :class:`SplitMlpExtractor`: SB3's ``MlpExtractor`` with the actor net reading a prefix of the features;
* :class:`CentralCriticPolicy` (PPO, A2C) and :class:`MaskableCentralCriticPolicy` (MaskablePPO):
  the actor-critic policies with that extractor, keyword ``actor_dim``. Saved models record the class
  and ``actor_dim`` (SB3's ``policy_kwargs``) and load with the algorithm's plain ``load``.
"""

from __future__ import annotations

from typing import Any

import torch as th
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import MlpExtractor
from torch import nn

__all__ = ["CentralCriticPolicy", "MaskableCentralCriticPolicy", "SplitMlpExtractor", "central_policy_class"]


class SplitMlpExtractor(MlpExtractor):
    """``MlpExtractor`` whose policy net reads ``features[..., :actor_dim]`` and whose value net reads all features."""

    def __init__(
        self,
        feature_dim: int,
        net_arch: list[int] | dict[str, list[int]],
        activation_fn: type[nn.Module],
        actor_dim: int,
        device: th.device | str = "auto",
    ) -> None:
        if not 1 <= actor_dim <= feature_dim:
            raise ValueError(f"actor_dim must be in [1, {feature_dim}] (the features' width), got {actor_dim}")
        super().__init__(feature_dim, net_arch, activation_fn, device)
        actor = MlpExtractor(actor_dim, net_arch, activation_fn, device)
        self.policy_net, self.latent_dim_pi = actor.policy_net, actor.latent_dim_pi
        self.actor_dim = int(actor_dim)

    def forward_actor(self, features: th.Tensor) -> th.Tensor:
        return self.policy_net(features[..., : self.actor_dim])


class _CentralCritic:
    """Mixin of an actor-critic policy: a :class:`SplitMlpExtractor` with keyword ``actor_dim``."""

    def __init__(self, *args: Any, actor_dim: int, **kwargs: Any) -> None:
        self.actor_dim = int(actor_dim)
        super().__init__(*args, **kwargs)

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = SplitMlpExtractor(
            self.features_dim, self.net_arch, self.activation_fn, self.actor_dim, device=self.device
        )

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "actor_dim": self.actor_dim}


class CentralCriticPolicy(_CentralCritic, ActorCriticPolicy):
    """PPO/A2C ``MlpPolicy`` with a centralised critic (the actor reads the first ``actor_dim`` inputs)."""


try:
    from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
except ImportError:  # sb3-contrib is optional: MaskablePPO (and this class) need it
    pass
else:

    class MaskableCentralCriticPolicy(_CentralCritic, MaskableActorCriticPolicy):
        """MaskablePPO ``MlpPolicy`` with a centralised critic (the actor reads the first ``actor_dim`` inputs)."""


def central_policy_class(algo: str) -> type:
    """The centralised-critic policy class of ``algo`` (``ppo``, ``a2c`` or ``maskable_ppo``)."""
    if algo == "maskable_ppo":
        return MaskableCentralCriticPolicy
    if algo in ("ppo", "a2c"):
        return CentralCriticPolicy
    raise ValueError(
        f"--critic central needs an actor-critic algorithm with a value function (ppo, a2c, maskable_ppo), not {algo}"
    )
