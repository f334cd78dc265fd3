"""Foraging's episode state lives in ``ForagingArrays`` (issue 24): one row per copy, bit for bit.

A batch binds its copies to rows of one shared ``ForagingArrays``; these tests check that every
copy of a batch (targets consumed, a lossy radio, ``persist``) steps exactly as a lone env with
its seed and actions, that lone envs and batches continue bit for bit after pickling and
``copy.deepcopy`` mid-episode, and that the env's per-episode values are views of its row.
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import teamgym
from teamgym.envs.foraging.state import ForagingArrays

CONFIGS = (
    {"n_robots": 2, "n_targets": 2, "consume_time": 0.5, "time_limit": 12.0},
    {"n_robots": 3, "comm_throughput": 0.6, "consumed_targets": "persist", "consume_time": 0.5, "time_limit": 10.0},
    {
        "n_robots": 3,
        "task": "surround",
        "robots_per_target": 2,
        "consume_time": 1.0,
        "time_limit": 8.0,
        "action_type": "velocity",
    },
)


def _actions(batch, rng):
    masks = batch.action_masks()
    if masks is None:
        space = batch.copies[0].action_space("robot_0")
        return rng.uniform(space.low, space.high, size=(batch.n_copies, batch.n_robots, *space.shape)).astype(space.dtype)
    return np.array([[rng.choice(np.flatnonzero(m)) for m in copy_masks] for copy_masks in masks])


def _lone_actions(env, row):
    return {a: row[env._row[a]] if np.ndim(row[env._row[a]]) else int(row[env._row[a]]) for a in env.agents}


def _same_rows(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[name], b[name], equal_nan=True) for name in a)


@pytest.mark.parametrize("config", CONFIGS, ids=["consume", "persist-radio", "surround-velocity"])
def test_every_copy_of_a_batch_steps_as_the_lone_env_with_its_seed(config):
    batch = teamgym.make_batch("Foraging-v0", 3, **config)
    lones = [teamgym.make("Foraging-v0", **config) for _ in range(3)]
    batch.reset(seed=40)
    for k, env in enumerate(lones):
        env.reset(seed=40 + k)
    shared = batch.copies[0]._arrays
    assert all(env._arrays is shared and env._copy == k for k, env in enumerate(batch.copies))
    rng = np.random.default_rng(0)
    for _ in range(120):
        if not batch.active.any():
            break
        arrays = _actions(batch, rng)
        observations, rewards, terminated, truncated = batch.step(arrays)
        for k, env in enumerate(lones):
            if not env.agents:
                continue
            obs, rew, term, trunc, infos = env.step(_lone_actions(env, arrays[k]))
            for agent in obs:
                i = env._row[agent]
                assert np.array_equal(observations[k, i], obs[agent]), (k, agent)
                assert (rew[agent], term[agent], trunc[agent]) == (rewards[k, i], terminated[k, i], truncated[k, i])
            assert _same_rows(shared.row(k), env._arrays.row(0)), k


def test_lone_env_continues_bit_for_bit_after_pickle_and_deepcopy_mid_episode():
    env = teamgym.make("Foraging-v0", n_robots=3, comm_throughput=0.7, consume_time=0.5)
    env.reset(seed=5)
    rng = np.random.default_rng(1)
    for _ in range(int(1.5 * env.rebase_cycles) + 7):  # past a re-base, so the copy starts from a snapshot
        env.step({a: int(rng.integers(env.action_space(a).n)) for a in env.agents})
    twins = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
    for twin in twins:
        assert twin._arrays is not env._arrays and _same_rows(twin._arrays.row(0), env._arrays.row(0))
        assert np.shares_memory(twin._pose, twin._arrays.pose) and np.shares_memory(twin.odometry.estimate, twin._arrays.estimate)
    for _ in range(40):
        if not env.agents:
            break
        actions = {a: int(rng.integers(env.action_space(a).n)) for a in env.agents}
        result = env.step(actions)
        for twin in twins:
            same = twin.step(actions)
            assert all(np.array_equal(same[0][a], result[0][a]) for a in result[0])
            assert same[1:4] == result[1:4]
            assert _same_rows(twin._arrays.row(0), env._arrays.row(0))


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_foraging_batch_continues_identically_after_copying(how):
    batch = teamgym.make_batch("Foraging-v0", 2, n_robots=3, comm_throughput=0.8)
    batch.reset(seed=3)
    rng = np.random.default_rng(2)
    for _ in range(25):
        batch.step(_actions(batch, rng))
    twin = pickle.loads(pickle.dumps(batch)) if how == "pickle" else copy.deepcopy(batch)
    shared = twin.copies[0]._arrays
    assert all(env._arrays is shared and env._copy == k for k, env in enumerate(twin.copies))
    for _ in range(15):
        arrays = _actions(batch, rng)
        a, b = batch.step(arrays), twin.step(arrays)
        assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert all(_same_rows(batch.copies[0]._arrays.row(k), shared.row(k)) for k in range(2))


def test_the_episode_values_are_views_of_the_env_row():
    env = teamgym.make("Foraging-v0")
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: 3 for a in env.agents})
    arrays = env._arrays
    for attribute in (*env._ROW_VIEWS, "_sightings"):
        value = getattr(env, attribute)
        for part in value[:2] if attribute == "_sightings" else (value,):
            assert any(np.shares_memory(part, getattr(arrays, name)) for name in arrays.arrays()), attribute
    assert np.shares_memory(env.odometry.estimate, arrays.estimate) and np.shares_memory(env.odometry.certainty, arrays.certainty)
    state = env._episode_state()
    assert "_foraging_row" in state and not set(env._ROW_VIEWS) & set(state) and "_arrays" not in state
    assert env._senses == 6  # the reset's sensing phase and one per step
    env.target_done_at[[2, 0]] = (4.0, 2.5)
    assert env._done_order == [2.5, 4.0]  # TT1, TT2 in order of time


def test_foraging_arrays_grow_shrink_rows_and_start():
    arrays = ForagingArrays(2, 3, 4, n_copies=1)
    assert arrays.table.shape == (1, 2, 5, 8) and arrays.targets.shape == (1, 3, 2)
    arrays.pose[0] = 1.5
    arrays.grow(3)
    assert arrays.n_copies == 3 and np.all(arrays.pose[0] == 1.5) and np.all(arrays.pose[1:] == 0.0)
    arrays.set_row(2, arrays.row(0))
    assert np.all(arrays.pose[2] == 1.5)
    arrays.start(2)
    assert np.all(arrays.pose[2] == 0.0) and np.all(arrays.at[2] == -1) and np.all(arrays.target_live[2])
    arrays.shrink(1)
    assert arrays.n_copies == 1 and arrays.at.shape == (1, 2)
    with pytest.raises(ValueError, match="n_robots=0"):
        ForagingArrays(0, 3, 4)


def test_packets_in_flight_hold_their_own_payloads():
    """A packet is a copy of its tuples: the sightings table (the copy's row) is rewritten at every sensing phase."""
    env = teamgym.make("Foraging-v0", n_robots=3, comm_latency=2)
    env.reset(seed=1)
    for _ in range(3):
        env.step({a: 0 for a in env.agents})
    in_flight = [copy[3][3] for copies in env.channel._in_flight.values() for copy in copies]
    assert in_flight and not any(np.shares_memory(payload, env._arrays.table) for payload in in_flight)
