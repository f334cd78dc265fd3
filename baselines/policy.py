"""The ``Policy`` interface shared by scripted baselines and trained agents."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from teamgym.envs.base import TeamEnv


class Policy(ABC):
    """Maps the observations of all live agents to their actions.

    A policy is built for one env (it may read the env's spaces, observation layout and
    config, never its hidden state unless the paper's method is centralised and the
    docstring says so), then used as::

        policy.reset(seed)
        actions = policy.act(observations, infos)
    """

    name: str = "policy"

    def __init__(self, env: TeamEnv) -> None:
        self.env = env
        self.np_random = np.random.default_rng()

    def reset(self, seed: int | None = None) -> None:
        """Start a new episode; ``seed`` makes any randomness of the policy repeatable."""
        self.np_random = np.random.default_rng(seed)

    @abstractmethod
    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        """Actions for every agent in ``observations``."""


class RandomPolicy(Policy):
    """Uniformly random actions from each agent's action space (seeded by ``reset``)."""

    name = "random"

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        for i, agent in enumerate(self.env.possible_agents):
            self.env.action_space(agent).seed(None if seed is None else seed + i)

    def act(self, observations, infos=None):
        return {agent: self.env.action_space(agent).sample() for agent in observations}
