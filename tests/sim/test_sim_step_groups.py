"""World.step's step groups: the one-pass robot hooks and the pymunk.batch body write give the same bits as robot by robot."""

from __future__ import annotations

import numpy as np
import pytest

import teamgym
from teamgym.sim import robot as robot_module
from teamgym.sim.chipmunk import BodyReader
from teamgym.sim.entity import StepGroup
from teamgym.sim.robot import RobotSteps


def _rollout(monkeypatch, bulk_from: int, **config) -> tuple[np.ndarray, list[float]]:
    monkeypatch.setattr(robot_module, "BULK_ROBOTS", bulk_from)
    env = teamgym.make("Navigation-v0", **config)
    env.reset(seed=2)
    rng = np.random.default_rng(0)
    n = len(env.robot_list)
    for _ in range(40):
        for robot, (v, omega) in zip(env.robot_list, rng.uniform([-0.3, -8.0], [0.3, 8.0], size=(n, 2)).tolist()):
            robot.set_command(v, omega if rng.random() > 0.2 else 0.0)  # straight lines too
        env.world.step()
    group = env.world._plan[0][0]
    assert isinstance(group, RobotSteps) and group.direct == (bulk_from > n)
    return env.world.states.copy(), [r.odometer for r in env.robot_list]


@pytest.mark.parametrize("config", [{"n_robots": 12}, {"n_robots": 10, "actuation_delay": 0.05}])
def test_control_bodies_set_in_one_batch_equal_robot_by_robot(monkeypatch, config):
    bulk, bulk_odometers = _rollout(monkeypatch, 8, **config)
    single, single_odometers = _rollout(monkeypatch, 10**6, **config)
    assert np.array_equal(bulk, single) and bulk_odometers == single_odometers


def test_writing_back_what_was_read_changes_nothing():
    env = teamgym.make("Navigation-v0", n_robots=4)
    env.reset(seed=5)
    space = env.world.space
    reader = BodyReader(list(space.bodies))
    before = reader.read(space).copy()
    assert reader.writable(space)
    reader.write(space)
    assert np.array_equal(BodyReader(list(space.bodies)).read(space), before)


def test_a_robot_class_with_its_own_hooks_is_stepped_robot_by_robot():
    class Logged(robot_module.DiffDriveRobot):
        def before_step(self, world, state):
            self.seen = tuple(state[:3])
            return super().before_step(world, state)

    from teamgym.sim.world import World

    world = World((1.0, 1.0))
    robot = world.add(Logged("r", (0.5, 0.5), 0.0))
    robot.set_command(0.1, 0.0)
    world.step()
    group = world._plan[0][0]
    assert type(group) is StepGroup and robot.seen == (0.5, 0.5, 0.0)
