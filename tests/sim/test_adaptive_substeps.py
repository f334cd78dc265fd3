"""Adaptive substeps (config ``coarse_substeps``; ``World(coarse_substeps=, contact_reach=)``).

A control step in which no contact can begin runs coarse; contacts are still resolved with the
fine substeps, so the penetration bound of tests/sim/test_physics.py holds; runs stay deterministic.
"""

import math

import numpy as np
import pytest

import teamgym
from teamgym.envs.config import ConfigError
from teamgym.sim import Category, DiffDriveRobot, RobotSpec, Wall, World

MAX_OVERLAP = 2e-3


def lone_robot_world(x: float) -> tuple[World, DiffDriveRobot]:
    world = World((1.0, 1.0), coarse_substeps=5, contact_reach=0.055)
    world.add(Wall("wall", (0.8, -5.0), (0.8, 6.0), 0.02))
    robot = world.add(DiffDriveRobot("r", (x, 0.5), 0.0, RobotSpec(max_wheel_speed=0.4)))
    return world, robot


def test_a_robot_far_from_everything_steps_coarse_and_one_near_a_wall_fine():
    world, _ = lone_robot_world(0.3)
    world.step()  # Chipmunk computes the bounding boxes in its first step
    world.step()
    assert world.coarse_steps >= 1
    world, _ = lone_robot_world(0.79 - 0.0275 - 0.03)  # rim 3 cm from the wall: within reach
    world.step()
    world.step()
    assert world.coarse_steps == 0 and world.fine_steps == 2


@pytest.mark.parametrize("angle_deg", [0, 45, 80])
def test_driving_into_a_wall_from_afar_never_penetrates(angle_deg, penetration_probe):
    world, robot = lone_robot_world(0.3)
    robot.teleport((0.3, 0.5), math.radians(angle_deg))
    probe = penetration_probe(world.space)
    spec = robot.spec
    for _ in range(100):
        robot.set_wheel_speeds(spec.max_wheel_speed, spec.max_wheel_speed)
        world.step()
    assert probe.calls > 0, "the robot never touched the wall"
    assert world.coarse_steps > 0 and world.fine_steps > 0 and world.coarse_contacts == 0
    assert probe.deepest(Category.ROBOT, Category.WALL) < MAX_OVERLAP


def test_crowded_episode_with_coarse_steps_keeps_overlaps_small(penetration_probe, random_policy):
    env = teamgym.make("Navigation-v0", n_robots=5, arena_size=1.2, min_goal_distance=0.3, max_cycles=150, coarse_substeps=5)
    env.reset(seed=2)
    probe = penetration_probe(env.world.space)
    rng = np.random.default_rng(2)
    while env.agents:
        env.step(random_policy(env, rng))
    assert env.world.coarse_steps > 0 and env.world.fine_steps > 0
    assert env.world.coarse_contacts == 0  # every contact began in a fine step
    assert frozenset({Category.ROBOT}) in probe.worst, "no robot-robot contact happened"
    for kind in (Category.ROBOT, Category.WALL, Category.OBSTACLE):
        assert probe.deepest(Category.ROBOT, kind) < MAX_OVERLAP


def test_off_by_default_and_deterministic_when_on(random_policy):
    env = teamgym.make("Navigation-v0")
    env.reset(seed=0)
    env.step(random_policy(env, np.random.default_rng(0)))
    assert env.world.coarse_substeps == 0 and env.world.coarse_steps == 0

    def run() -> list[np.ndarray]:
        env = teamgym.make("Navigation-v0", coarse_substeps=4)
        observations, _ = env.reset(seed=3)
        rng = np.random.default_rng(3)
        seen = []
        for _ in range(60):
            if not env.agents:
                break
            observations, *_ = env.step(random_policy(env, rng))
            seen.extend(observations.values())
        return seen

    first, second = run(), run()
    assert len(first) == len(second) and all(np.array_equal(a, b) for a, b in zip(first, second))


@pytest.mark.parametrize(
    ("value", "reason"),
    [(-1, r"it must be in \[0, 1000\]"), (21, r"substeps=20 do not fit together; coarse_substeps must not exceed")],
)
def test_invalid_coarse_substeps_is_a_one_line_config_error(value, reason):
    with pytest.raises(ConfigError, match=rf"coarse_substeps={value}.* {reason}"):
        teamgym.make("Navigation-v0", coarse_substeps=value)


def test_world_rejects_inconsistent_substep_settings():
    with pytest.raises(ValueError, match="coarse_substeps <= substeps"):
        World((1.0, 1.0), substeps=10, coarse_substeps=11)
