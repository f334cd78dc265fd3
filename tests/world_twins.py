"""Worlds and their deep-copied twins driven by the same random commands (tests of worlds stepped together)."""

import copy

import numpy as np

import teamgym


def envs_and_twins(env_id: str, n: int, first_seed: int, **config) -> tuple[list, list]:
    """``n`` envs reset with seeds ``first_seed``, ``first_seed + 1``, … and a deep copy of each."""
    envs = []
    for k in range(n):
        env = teamgym.make(env_id, **config)
        env.reset(seed=first_seed + k)
        envs.append(env)
    return envs, [copy.deepcopy(env) for env in envs]


def command_both(envs: list, twins: list, rng: np.random.Generator) -> None:
    """Give each robot and its twin the same random body command."""
    for env, twin in zip(envs, twins):
        for robot, other in zip(env.world.robots, twin.world.robots):
            v, omega = rng.uniform(-0.3, 0.3), rng.uniform(-2.0, 2.0)
            robot.set_command(v, omega)
            other.set_command(v, omega)
