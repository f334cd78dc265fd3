"""Exploration-v0 (paper 000): see :mod:`teamgym.envs.exploration.env`."""

from teamgym.envs.exploration.config import ExplorationConfig
from teamgym.envs.exploration.env import Exploration, env, parallel_env

__all__ = ["Exploration", "ExplorationConfig", "env", "parallel_env"]
