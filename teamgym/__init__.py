"""teamgym: PettingZoo multi-robot environments on a shared pymunk simulator.

>>> import teamgym
>>> env = teamgym.make("Navigation-v0", n_robots=5)
>>> observations, infos = env.reset(seed=0)
"""

from teamgym.envs.base import EpisodeOverError, TeamEnv
from teamgym.envs.config import ConfigError
from teamgym.registry import env_class, envs, make, make_aec, register

__version__ = "0.1.0"

__all__ = ["ConfigError", "EpisodeOverError", "TeamEnv", "env_class", "envs", "make", "make_aec", "register", "__version__"]
