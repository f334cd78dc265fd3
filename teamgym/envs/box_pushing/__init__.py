"""BoxPushing-v0 and -v1 (paper 004): see :mod:`teamgym.envs.box_pushing.env`."""

from teamgym.envs.box_pushing.config import SITUATIONS, BoxPushingConfig, BoxPushingV1Config
from teamgym.envs.box_pushing.env import BoxPushing, BoxPushingV1, env, parallel_env

__all__ = ["SITUATIONS", "BoxPushing", "BoxPushingConfig", "BoxPushingV1", "BoxPushingV1Config", "env", "parallel_env"]
