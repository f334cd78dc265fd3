"""BoxPushing's episode state lives in ``BoxPushingArrays`` (issue 24): one row per copy, bit for bit.

A batch binds its copies to rows of one shared ``BoxPushingArrays`` and computes box gaps,
deliveries, success, rewards and observations over the copies at once; these tests check
that copies with run-time events (robots added, removed, broken down; boxes added), copies
that stop early (rows stepped out of order) and copies after pickling step exactly as lone
envs, and that the env keeps no episode state in attributes of its own.
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import teamgym
from teamgym.envs.box_pushing.state import LEAVING, BoxPushingArrays
from teamgym.sim.world_group import GroupPlans

EVENTS = (
    (3, "add_robot"),
    (5, "break_down", "robot_1"),
    (6, "add_light_box"),
    (8, "remove_robot", "robot_0"),
    (9, "remove_robot", "robot_0"),  # skipped: robot_0 is gone
)
CONFIG = {"situation": "S2", "max_cycles": 40, "n_spare_robots": 1, "n_spare_boxes": 1, "events": EVENTS}

#: What a BoxPushing env holds besides what ``TeamEnv`` sets: derived from the config once
#: (``_setup``), the simulated objects of the episode (``boxes``), and its row of the arrays.
ALLOWED = {
    "spec_robot", "ring", "light", "encoder_limit", "sensors", "goal", "object_threshold", "primitive_params",
    "events", "box_capacity", "state_space", "_arrays", "_copy", "boxes",
}  # fmt: skip


def _base_attributes() -> set[str]:
    import inspect
    import re

    from teamgym.envs.base import TeamEnv

    return set(re.findall(r"self\.(\w+)\s*(?::[^=\n]+)?=(?!=)", inspect.getsource(TeamEnv))) | {"_phases", "reset_options"}


def _actions(batch, rng):
    masks = batch.action_masks()
    return rng.integers(0, 13, size=(batch.n_copies, batch.n_robots)) if masks is None else np.argmax(masks, axis=-1)


def _step_both(batch, lones, arrays):
    observations, rewards, terminated, truncated = batch.step(arrays)
    for k, env in enumerate(lones):
        if not env.agents:
            assert not batch.active[k].any()
            continue
        obs, rew, term, trunc, infos = env.step({a: int(arrays[k, env._row[a]]) for a in env.agents})
        batch_infos = batch.infos(k)
        for agent in obs:
            i = env._row[agent]
            assert np.array_equal(observations[k, i], obs[agent]), (k, agent)
            assert (rew[agent], term[agent], trunc[agent]) == (rewards[k, i], terminated[k, i], truncated[k, i])
            assert all(
                batch_infos[agent][key] == value or (value != value and batch_infos[agent][key] != batch_infos[agent][key])
                for key, value in infos[agent].items()
            ), (k, agent)
        assert batch.copies[k].skipped_events == env.skipped_events
        rows, lone_rows = batch.copies[k]._arrays.row(k), env._arrays.row(0)
        assert all(np.array_equal(rows[name], lone_rows[name], equal_nan=True) for name in rows), k


def test_the_env_keeps_no_episode_state_outside_its_arrays():
    env = teamgym.make("BoxPushing-v0", **CONFIG)
    env.reset(seed=2)
    for _ in range(10):
        env.step({a: 6 for a in env.agents})
    assert set(vars(env)) - _base_attributes() <= ALLOWED
    assert isinstance(env._arrays, BoxPushingArrays) and env._arrays.n_copies == 1
    team = env._arrays
    assert team.status[0, env._row["robot_1"]] == LEAVING["broken_down"] and team.status[0, 0] == LEAVING["removed"]
    assert team.n_boxes[0] == 3 and team.robots_used[0] == 3 and team.next_event[0] == len(EVENTS)
    assert [e.cycle for e in env.skipped_events] == [9]  # robot_0 was already gone
    assert set(env.executors) == set(env.possible_agents)  # the action type's, one per robot


@pytest.mark.parametrize(
    ("env_id", "extra", "K"),
    [
        ("BoxPushing-v0", {}, 3),
        ("BoxPushing-v1", {}, 3),  # noisy sensors and motors, light gains
        ("BoxPushing-v1", {"light_shadows": True}, 3),  # the light's line-of-sight queries, copy by copy
        ("BoxPushing-v0", {}, 7),  # 21+ robots: the worlds step together, their plans change with the events
    ],
)
def test_batch_copies_with_events_step_as_lone_envs_and_share_one_arrays(env_id, extra, K):
    batch = teamgym.make_batch(env_id, K, **CONFIG, **extra)
    lones = [teamgym.make(env_id, **CONFIG, **extra) for _ in range(K)]
    batch.reset(seed=11)
    if K > 3:  # step the worlds together with or without the compiled kernel (thresholds: 16 robots compiled, 128 in Python)
        batch._phases._group_plans = GroupPlans(min_robots=8)
    for k, env in enumerate(lones):
        env.reset(seed=11 + k)
    assert len({id(env._arrays) for env in batch.copies}) == 1 and [env._copy for env in batch.copies] == list(range(K))
    rng = np.random.default_rng(3)
    for step in range(14):
        if step == 10:  # copy 1 ends early: the copies stepped are rows 0 and 2 only
            for env in (batch.copies[1], lones[1]):
                for agent in list(env.agents):
                    env.remove_robot(agent)
        _step_both(batch, lones, _actions(batch, rng))
    assert not batch.active[1].any() and batch.active[[0, 2]].any()
    if K > 3:  # the events changed the worlds' plans while their group stepped together
        assert batch._phases._group_plans._together is not None
    if env_id == "BoxPushing-v1":
        assert not np.all(batch.copies[0]._arrays.light_gains == 1.0)  # calibrated rows, not the default


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_copy_of_a_batch_or_env_keeps_its_rows(how):
    batch = teamgym.make_batch("BoxPushing-v0", 2, **CONFIG)
    batch.reset(seed=4)
    rng = np.random.default_rng(0)
    for _ in range(7):
        batch.step(_actions(batch, rng))
    clone = pickle.loads(pickle.dumps(batch)) if how == "pickle" else copy.deepcopy(batch)
    lone = pickle.loads(pickle.dumps(batch.copies[1])) if how == "pickle" else copy.deepcopy(batch.copies[1])
    assert lone._arrays.n_copies == 1 and clone.copies[1]._arrays is clone.copies[0]._arrays
    for _ in range(6):
        arrays = _actions(batch, rng)
        for a, b in zip(batch.step(arrays), clone.step(arrays)):
            assert np.array_equal(a, b)
        if lone.agents:
            lone.step({agent: int(arrays[1, lone._row[agent]]) for agent in lone.agents})
        assert all(np.array_equal(v, lone._arrays.row(0)[n], equal_nan=True) for n, v in batch.copies[1]._arrays.row(1).items())


def test_a_batch_whose_other_copies_ended_steps_its_last_copy_as_a_lone_env():
    batch = teamgym.make_batch("BoxPushing-v0", 2, **CONFIG)
    lones = [teamgym.make("BoxPushing-v0", **CONFIG) for _ in range(2)]
    batch.reset(seed=21)
    for k, env in enumerate(lones):
        env.reset(seed=21 + k)
    rng = np.random.default_rng(5)
    for step in range(14):
        if step == 10:  # after the events copy 0 ends: the group of the later steps is copy 1 alone
            for env in (batch.copies[0], lones[0]):
                for agent in list(env.agents):
                    env.remove_robot(agent)
        _step_both(batch, lones, _actions(batch, rng))
    assert not batch.active[0].any() and batch.active[1].any()
