"""Worlds stepped together (``teamgym.sim.world_group``) end each step exactly as each stepped alone."""

import copy
import pickle

import numpy as np
import pytest

import teamgym
from teamgym.sim.world_group import GroupPlans, group_plan, step_worlds
from tests.world_twins import command_both, envs_and_twins


def _worlds(env_id: str, n: int, **config) -> list:
    envs = []
    for k in range(n):
        env = teamgym.make(env_id, **config)
        env.reset(seed=100 + k)
        envs.append(env)
    return envs


def _snapshot(world) -> tuple:
    robots = [(r.command, r.applied_command, r.encoders, r.odometer) for r in world.robots]
    movers = [getattr(m, "target_velocity", None) for m in world.movers]
    return world.read_states()[0].tobytes(), world.states.tobytes(), robots, movers, world.time, world.fine_steps


@pytest.mark.parametrize(
    ("env_id", "config", "plans"),
    [
        ("Navigation-v0", {}, True),  # centre pivots, bouncing obstacles, a writable body buffer
        ("BoxPushing-v1", {}, True),  # wheel feet: an anchor per drive
        ("Exploration-v0", {}, True),  # a map of walls: control bodies set one by one
        ("Navigation-v0", {"actuation_delay": 0.05}, True),  # a delay: every world steps alone
    ],
)
def test_worlds_stepped_together_equal_worlds_stepped_alone(env_id, config, plans):
    envs, twins = envs_and_twins(env_id, 4, 100, **config)
    grouped = GroupPlans(min_robots=0)  # four worlds: below the default threshold
    rng = np.random.default_rng(0)
    for _ in range(30):
        command_both(envs, twins, rng)
        for env, twin in zip(envs, twins):
            if config.get("actuation_delay"):
                for robot, other in zip(env.world.robots, twin.world.robots):
                    robot.actuation_delay = other.actuation_delay = 0.05
        grouped.step([env.world for env in envs])
        for twin in twins:
            twin.world.step()
        for env, twin in zip(envs, twins):
            assert _snapshot(env.world) == _snapshot(twin.world)
    assert (group_plan(envs[0].world) is not None) is plans


def test_a_world_that_cannot_step_together_steps_alone():
    """A world without a plan (here: adaptive substeps) steps through ``World.step`` beside the others."""
    envs = _worlds("Navigation-v0", 3)
    twins = [copy.deepcopy(env) for env in envs]
    envs[1].world.coarse_substeps = twins[1].world.coarse_substeps = 4
    worlds = [env.world for env in envs]
    plans = [group_plan(world) for world in worlds]
    assert plans[1] is None and plans[0] is not None
    for _ in range(20):
        step_worlds(worlds, plans)
        for twin in twins:
            twin.world.step()
    for env, twin in zip(envs, twins):
        assert _snapshot(env.world) == _snapshot(twin.world)
    assert envs[1].world.coarse_steps == twins[1].world.coarse_steps > 0


def test_a_small_group_steps_world_by_world_and_a_large_one_together():
    """Below ``min_robots`` the worlds step alone (no :class:`StepTogether`), at or above it together; same bits."""
    envs = _worlds("Navigation-v0", 2)  # 3 robots each
    twins = [copy.deepcopy(env) for env in envs]
    small, large = GroupPlans(min_robots=7), GroupPlans(min_robots=6)
    for _ in range(3):
        small.step([envs[0].world, envs[1].world])
        large.step([twins[0].world, twins[1].world])
    assert small._together is None and large._together is not None
    for env, twin in zip(envs, twins):
        assert _snapshot(env.world) == _snapshot(twin.world)


def test_a_pickled_group_keeps_its_threshold():
    assert pickle.loads(pickle.dumps(GroupPlans(min_robots=5))).min_robots == 5
    assert pickle.loads(pickle.dumps(GroupPlans())).min_robots == GroupPlans().min_robots


@pytest.mark.parametrize(("env_id", "config"), [("Navigation-v0", {}), ("BoxPushing-v1", {}), ("Rendezvous-v0", {})])
def test_a_group_that_shrinks_steps_its_remaining_worlds_as_each_alone(env_id, config):
    """Copies leaving a macro stage one by one: after a step of all worlds, changing subsets of them step (picked from
    the whole group's arrays, :meth:`StepTogether.subset`) and every world still equals its twin stepped alone."""
    from teamgym.sim import kernel

    if not kernel.enabled():
        pytest.skip("subsets are picked from the compiled group (teamgym[fast])")
    envs, twins = envs_and_twins(env_id, 6, 300, **config)
    grouped = GroupPlans(min_robots=0)
    rng = np.random.default_rng(1)
    subsets = [range(6), [0, 2, 3, 5], [2, 3, 5], [3], range(6), [1, 4], [0, 1, 2, 3, 4]]
    picked = 0
    for _ in range(4):
        for members in subsets:
            members = list(members)
            command_both([envs[m] for m in members], [twins[m] for m in members], rng)
            whole = grouped._whole
            grouped.step([envs[m].world for m in members], reuse_states=True)
            picked += grouped._whole is whole and len(members) < 6
            for m in members:
                twins[m].world.step(reuse_states=True)
            for env, twin in zip(envs, twins):
                assert _snapshot(env.world) == _snapshot(twin.world)
    assert picked > 0
