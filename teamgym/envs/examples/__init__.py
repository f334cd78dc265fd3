"""Example envs that document how to write one; not registered (see ``docs/adding_an_env.md``).

``from teamgym.envs.examples.beacon import parallel_env`` makes the Beacon example.
"""

from teamgym.envs.examples.beacon import Beacon, BeaconConfig, env, parallel_env

__all__ = ["Beacon", "BeaconConfig", "env", "parallel_env"]
