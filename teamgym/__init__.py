"""teamgym: PettingZoo multi-robot environments on a shared pymunk simulator.

>>> import teamgym
>>> env = teamgym.make("Navigation-v0", n_robots=5)
>>> observations, infos = env.reset(seed=0)
>>> batch = teamgym.make_batch("Navigation-v0", 16, n_robots=3)  # 16 copies, arrays in and out
"""

from teamgym.envs.base import EpisodeOverError, TeamEnv
from teamgym.envs.config import ConfigError
from teamgym.registry import env_class, envs, make, make_aec, make_batch, register

__version__ = "0.1.0"

__all__ = [
    "ConfigError",
    "EpisodeOverError",
    "TeamEnv",
    "env_class",
    "envs",
    "make",
    "make_aec",
    "make_batch",
    "register",
    "__version__",
]
