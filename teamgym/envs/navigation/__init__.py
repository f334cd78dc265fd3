"""Navigation-v0 (paper 001): see :mod:`teamgym.envs.navigation.env`."""

from teamgym.envs.navigation.config import NavigationConfig
from teamgym.envs.navigation.env import Navigation, env, parallel_env

__all__ = ["Navigation", "NavigationConfig", "env", "parallel_env"]
