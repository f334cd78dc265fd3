"""The compiled step kernel (``teamgym.sim.kernel``) leaves every world as the Python path does."""

import copy
import os
import subprocess
import sys

import numpy as np
import pymunk
import pytest

import teamgym
from teamgym.sim import kernel
from teamgym.sim.world_group import GroupPlans
from tests.world_twins import command_both, envs_and_twins

needs_kernel = pytest.mark.skipif(not kernel.enabled(), reason="numba not installed (the fast extra) or kernel switched off")


@pytest.fixture
def restore_switch():
    yield
    kernel.set_enabled(os.environ.get(kernel.ENV_FLAG, "1") not in ("0", "false", "no", "off"))


def _snapshot(world) -> tuple:
    robots = [(r.command, r.applied_command, r.encoders, r.odometer) for r in world.robots]
    movers = [getattr(m, "target_velocity", None) for m in world.movers]
    bodies = [(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in world.space.bodies]
    anchors = [tuple(c.anchor_a) for c in world.space.constraints if isinstance(c, pymunk.PivotJoint)]
    return world.states.tobytes(), robots, movers, bodies, anchors, world.time, world.fine_steps


@needs_kernel
@pytest.mark.parametrize("env_id", ["Navigation-v0", "BoxPushing-v0", "BoxPushing-v1", "Exploration-v0", "Foraging-v0"])
def test_compiled_step_leaves_the_worlds_as_the_python_step(env_id, restore_switch):
    """Same commands, one set of worlds through the kernel and a deep copy through Python: same bits every step."""
    envs, twins = envs_and_twins(env_id, 4, 300)
    compiled, in_python = GroupPlans(min_robots=0), GroupPlans(min_robots=0)
    rng = np.random.default_rng(1)
    for _ in range(40):
        command_both(envs, twins, rng)
        kernel.set_enabled(True)
        compiled.step([env.world for env in envs], reuse_states=True)
        kernel.set_enabled(False)
        in_python.step([twin.world for twin in twins], reuse_states=True)
        for env, twin in zip(envs, twins):
            assert _snapshot(env.world) == _snapshot(twin.world)
    assert compiled._together._compiled is not None  # the kernel did step them
    assert in_python._together._compiled is None


def _nothing() -> tuple:
    """No control bodies, obstacles or drives for :meth:`WorldsKernel.step`."""
    handles = np.zeros(0, dtype=np.uint64)
    return handles, np.zeros((0, 6)), handles, np.zeros((0, 2)), handles, np.zeros((0, 2))


@needs_kernel
def test_a_space_that_gained_a_body_is_reported_and_a_new_kernel_reads_it():
    spaces = [kernel._scratch_space(k) for k in range(2)]
    worlds_kernel = kernel.WorldsKernel(spaces)
    spaces[1].add(pymunk.Body(body_type=pymunk.Body.STATIC))
    with pytest.raises(kernel.KernelError, match="world 1"):
        worlds_kernel.step(*_nothing(), 5, 0.01)
    again = kernel.WorldsKernel(spaces)
    assert again.read().shape == (sum(len(space.bodies) for space in spaces), 6) == (5, 6)
    assert [tuple(row) for row in again.buffer.tolist()] == [row for space in spaces for row in kernel._body_rows(space)]


@needs_kernel
def test_the_buffer_rows_are_the_bodies():
    spaces = [kernel._scratch_space(k) for k in range(3)]
    worlds_kernel = kernel.WorldsKernel(spaces)
    discs = [kernel._disc_of(space) for space in spaces]
    rows = np.concatenate([worlds_kernel.body_rows(m, [disc]) for m, disc in enumerate(discs)])
    handles, values, movers, velocities, _, _ = _nothing()
    joints = kernel.joint_handles([kernel._pivot_of(space) for space in spaces])
    buffer = worlds_kernel.step(handles, values, movers, velocities, joints, np.zeros((3, 2)), 2, 0.01)
    expected = [(*d.position, d.angle, *d.velocity, d.angular_velocity) for d in discs]
    assert [tuple(row) for row in buffer[rows].tolist()] == expected


def test_switched_off_the_worlds_step_in_python(restore_switch):
    kernel.set_enabled(False)
    assert not kernel.enabled()
    env = teamgym.make("Navigation-v0")
    env.reset(seed=0)
    worlds = [env.world, copy.deepcopy(env).world]
    plans = GroupPlans(min_robots=0)
    for _ in range(3):
        plans.step(worlds)
    assert plans._together is not None and plans._together._compiled is None


def test_the_environment_variable_switches_the_kernel_off():
    code = "from teamgym.sim import kernel; print(kernel.enabled())"
    done = subprocess.run(
        [sys.executable, "-c", code], env={**os.environ, kernel.ENV_FLAG: "0"}, capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "False"


@needs_kernel
def test_rows_read_elsewhere_or_bodies_moved_between_steps_are_read_again(restore_switch):
    """A world that re-read its rows (so they are not the kernel's), stepped alone for a step (a
    delay), or had a body moved by hand (``reuse_states=False``) starts the next compiled step from
    the space as it is."""
    envs, twins = envs_and_twins("Navigation-v0", 4, 500)
    compiled, in_python = GroupPlans(min_robots=0), GroupPlans(min_robots=0)
    rng = np.random.default_rng(2)
    for step in range(24):
        command_both(envs, twins, rng)
        moved = step % 6 == 5
        if step % 4 == 3:
            envs[1].world.read_states()
            twins[1].world.read_states()
        if moved:  # push one robot by hand in both copies
            for env in (envs[2], twins[2]):
                robot = env.world.robots[0]
                for body in (robot.body, robot.control):
                    body.position = (body.position.x + 0.01, body.position.y)
        for env in (*envs, *twins):  # one step with an actuation delay: every world steps alone
            for robot in env.world.robots:
                robot.actuation_delay = 0.05 if step == 13 else 0.0
        kernel.set_enabled(True)
        compiled.step([env.world for env in envs], reuse_states=not moved)
        kernel.set_enabled(False)
        in_python.step([twin.world for twin in twins], reuse_states=not moved)
        for env, twin in zip(envs, twins):
            assert _snapshot(env.world) == _snapshot(twin.world)
    assert compiled._together._compiled is not None


@pytest.mark.skipif(os.environ.get("TEAMGYM_FLOORS") != "1", reason="only in the floor run (scripts/run_tests_floors.sh)")
def test_the_floor_run_steps_every_world_in_python():
    """The floor-version run installs no numba, so the whole suite there runs the Python path the kernel is checked against."""
    assert not kernel.enabled()
    with pytest.raises(ImportError):
        import numba  # noqa: F401
