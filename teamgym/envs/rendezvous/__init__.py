"""Rendezvous-v0 (paper 003): see :mod:`teamgym.envs.rendezvous.env`."""

from teamgym.envs.rendezvous.config import RendezvousConfig
from teamgym.envs.rendezvous.env import Rendezvous, env, parallel_env

__all__ = ["Rendezvous", "RendezvousConfig", "env", "parallel_env"]
