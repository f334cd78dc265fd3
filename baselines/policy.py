"""The ``Policy`` interface shared by scripted baselines and trained agents."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from teamgym.envs.base import TeamEnv


class Policy(ABC):
    """Maps the observations of all live agents to their actions.

    A policy is built for one env (it may read the env's spaces, observation layout and
    config, never its hidden state unless the paper's method is centralised and the
    docstring says so), then used as::

        policy.reset(seed)
        actions = policy.act(observations, infos)

    What a policy needs from its env is declared in ``env_ids`` and ``observation_fields``
    and checked by :meth:`check_env` (``make_policy`` calls it); a constructor may check
    more (e.g. the action type) and raise naming what is wrong.
    """

    name: str = "policy"
    #: Env ids (``teamgym.envs()``) the policy is written for; empty: any env.
    env_ids: ClassVar[tuple[str, ...]] = ()
    #: Observation fields (names of ``env.layout``) the policy decodes; empty: none.
    observation_fields: ClassVar[tuple[str, ...]] = ()
    #: Whether the policy's continuous actions are in the action type's native units (scripted
    #: policies); such a policy cannot drive an env built with ``normalize_actions=True``.
    native_actions: ClassVar[bool] = True

    def __init__(self, env: TeamEnv) -> None:
        self.env = env
        self.np_random = np.random.default_rng()

    def reset(self, seed: int | None = None) -> None:
        """Start a new episode; ``seed`` makes any randomness of the policy repeatable."""
        self.np_random = np.random.default_rng(seed)

    @classmethod
    def check_env_id(cls, env_id: str | None, name: str | None = None) -> None:
        """Raise ``ValueError`` if the policy is not written for env id ``env_id`` (``None``: an unregistered env)."""
        if cls.env_ids and env_id not in cls.env_ids:
            what = env_id or "an unregistered env"
            raise ValueError(f"policy {name or cls.name!r} does not fit {what}: it is written for {', '.join(cls.env_ids)}")

    @classmethod
    def check_env(cls, env: TeamEnv, name: str | None = None) -> None:
        """Raise ``ValueError`` naming the policy, the env and what is missing if the policy cannot drive ``env``."""
        if cls.native_actions and getattr(getattr(env, "config", None), "normalize_actions", False):
            raise ValueError(
                f"policy {name or cls.name!r} acts in native units and cannot drive an env with normalize_actions=True "
                "(evaluate it without: the task is the same)"
            )
        if not (cls.env_ids or cls.observation_fields):
            return
        env_id = env_id_of(env)
        cls.check_env_id(env_id, name)
        have = list(getattr(getattr(env, "layout", None), "slices", ()))
        missing = [f for f in cls.observation_fields if f not in have]
        if missing:
            what = env_id or type(env).__name__
            raise ValueError(
                f"policy {name or cls.name!r} does not fit {what}: its observations lack the field(s) "
                f"{', '.join(missing)} that the policy reads (they have: {', '.join(have) or 'no named fields'})"
            )

    @abstractmethod
    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        """Actions for every agent in ``observations``."""


class RandomPolicy(Policy):
    """Uniformly random actions from each agent's action space (seeded by ``reset``); admissible ones where the env masks."""

    name = "random"
    native_actions = False  # samples the env's own action space

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        for i, agent in enumerate(self.env.possible_agents):
            self.env.action_space(agent).seed(None if seed is None else seed + i)

    def act(self, observations, infos=None):
        infos = infos or {}
        return {
            agent: self.env.action_space(agent).sample(mask=infos.get(agent, {}).get("action_mask")) for agent in observations
        }


def env_id_of(env: Any) -> str | None:
    """The registered id of ``env``'s class (``"Navigation-v0"``, ...), or ``None`` if it has none."""
    from teamgym.registry import env_class, envs

    classes = {env_id: env_class(env_id) for env_id in envs()}
    exact = [env_id for env_id, cls in classes.items() if type(env) is cls]
    derived = [env_id for env_id, cls in classes.items() if isinstance(env, cls)]
    return (exact or derived or [None])[0]
