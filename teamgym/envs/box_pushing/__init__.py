"""BoxPushing-v0 (paper 004): see :mod:`teamgym.envs.box_pushing.env`."""

from teamgym.envs.box_pushing.config import SITUATIONS, BoxPushingConfig
from teamgym.envs.box_pushing.env import BoxPushing, env, parallel_env

__all__ = ["SITUATIONS", "BoxPushing", "BoxPushingConfig", "env", "parallel_env"]
