"""``Foraging-v0``: consuming and surrounding with limited perception and a lossy radio (paper 002)."""

from teamgym.envs.foraging.config import ForagingConfig
from teamgym.envs.foraging.env import Foraging, env, parallel_env

__all__ = ["Foraging", "ForagingConfig", "env", "parallel_env"]
