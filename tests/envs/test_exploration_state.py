"""Exploration batches over ``ExplorationArrays`` (``ExplorationPhases``), copy by copy against lone envs.

Six copies at once (places, the explored set, goals, rewards and observations over the group in
numpy) for velocities and operators, with door re-sampling and doors toggled mid-episode,
collisions that fail tasks, noisy rings, ``stage_end="all"``, learned messages, copies that
finish early (the group becomes an index array), auto-reset and pickling mid-episode: every
copy's observations, rewards, terminations, truncations and infos equal a lone env's with its
seed and actions, bit for bit. Then the vectorised place rule against the lone env's, and the
arrays' grow, shrink and start.
"""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import pytest

import teamgym
from teamgym.envs.exploration.state import ExplorationArrays
from tests.batch_lockstep import same

CONFIGS = {
    "velocity-doors": {"door_resample_period": 1.0, "sensor_noise": 0.005, "max_cycles": 120},
    "velocity-near-goal": {"goal_sectors": ("S3",), "max_cycles": 300},  # copies 1 and 5 start with a robot in S3
    "operator-any": {"action_type": "operator", "fail_on_collision": True, "door_resample_period": 20.0, "max_cycles": 1500},
    "operator-all": {"action_type": "operator", "stage_end": "all", "n_robots": 4, "max_cycles": 1200},
    "operator-dict-comm": {"action_type": "operator", "obs_format": "dict", "comm_dim": 2, "max_cycles": 800},
    "velocity-dict-two": {"n_robots": 2, "obs_format": "dict", "max_cycles": 150},
}
K = 6


def draw(batch, rng):
    """Actions ``(K, N, ...)`` for the batch and per copy ``[row] -> action`` for the lone envs."""
    space = batch.action_space
    motion = space["motion"] if hasattr(space, "spaces") else space
    masks = batch.action_masks()
    shape = (batch.n_copies, batch.n_robots)
    if masks is not None:
        moves = np.array([[rng.choice(np.flatnonzero(m)) for m in rows] for rows in masks])
    else:
        moves = rng.uniform(motion.low, motion.high, size=(*shape, *motion.shape)).astype(motion.dtype)
    if hasattr(space, "spaces"):
        message = rng.uniform(-1, 1, size=(*shape, *space["message"].shape)).astype(np.float32)
        per_copy = [[{"motion": moves[k, i], "message": message[k, i]} for i in range(shape[1])] for k in range(shape[0])]
        return {"motion": moves, "message": message}, per_copy
    return moves, [list(row) for row in moves]


def lone_action(value):
    if isinstance(value, dict):
        return {key: lone_action(v) for key, v in value.items()}
    return int(value) if np.ndim(value) == 0 and np.issubdtype(np.asarray(value).dtype, np.integer) else value


def row_of(observations, k, i):
    if isinstance(observations, dict):
        return {key: value[k, i] for key, value in observations.items()}
    return observations[k, i]


def check_step(batch, lones, arrays, rows, toggles=()) -> int:
    """Step the batch and the lone envs alike (after the same door ``toggles``); compare; how many lone envs stepped."""
    for k, door, is_open in toggles:
        assert batch.copies[k].set_door(door, is_open) == lones[k].set_door(door, is_open)
    observations, rewards, terminated, truncated = batch.step(arrays)
    stepped = 0
    for k, env in enumerate(lones):
        if not env.agents:
            assert not batch.active[k].any()
            continue
        stepped += 1
        obs, rew, term, trunc, infos = env.step({a: lone_action(rows[k][env._row[a]]) for a in env.agents})
        for agent in obs:
            i = env._row[agent]
            assert same(row_of(observations, k, i), obs[agent]), (k, agent)
            assert (rewards[k, i], terminated[k, i], truncated[k, i]) == (rew[agent], term[agent], trunc[agent]), (k, agent)
        assert same(batch.infos(k), infos), k
        assert np.array_equal(batch.copies[k].state(), env.state())
    return stepped


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_every_copy_of_an_exploration_batch_steps_as_its_lone_env(name):
    config = CONFIGS[name]
    batch = teamgym.make_batch("Exploration-v0", K, **config)
    lones = [teamgym.make("Exploration-v0", **config) for _ in range(K)]
    observations = batch.reset(seed=11)
    for k, env in enumerate(lones):
        first, _ = env.reset(seed=11 + k)
        for agent, value in first.items():
            assert same(row_of(observations, k, env._row[agent]), value)
    rng, doors, partial_groups = np.random.default_rng(3), batch.copies[0].map.door_ids, 0
    for step in range(40):
        if batch.episode_over().all():
            break
        toggles = [(k, doors[(step + k) % len(doors)], bool(step % 2)) for k in range(K) if lones[k].agents and step % 7 == 3]
        arrays, rows = draw(batch, rng)
        stepped = check_step(batch, lones, arrays, rows, toggles)
        partial_groups += 1 < stepped < K
    team = batch.copies[0]._arrays
    assert all(env._arrays is team and env._copy == k for k, env in enumerate(batch.copies))
    if name == "velocity-near-goal":
        assert partial_groups > 0 and team.explored_all[[1, 5]].all()  # copies ended early: later groups skip them
    if name.startswith("operator"):
        assert team.stages.min() > 1 and (team.completed + team.failed).sum() > 0
    if name == "operator-any":
        assert team.clutter_count.sum() > 0  # executed FindDoor tasks re-estimated clutter (eq. 2)


def test_auto_reset_pickling_and_deepcopy_keep_every_copy_on_its_lone_course():
    config = {"action_type": "operator", "door_resample_period": 5.0, "max_cycles": 640}
    batch = teamgym.make_batch("Exploration-v0", 4, auto_reset=True, **config)
    batch.reset(seed=2)
    rng, restarted, rebased = np.random.default_rng(0), 0, 0
    for _ in range(400):
        batch.step(draw(batch, rng)[0])
        restarted += len(batch.final_infos)
        rebased += sum(env._log[0][0] == "base" for env in batch.copies)
        if restarted and 0 < batch.copies[0].cycles < 600:
            break
    assert rebased and restarted  # copies re-based on the way, and some ended and started again
    clone, restored = copy.deepcopy(batch), pickle.loads(pickle.dumps(batch))
    for _ in range(10):
        arrays = draw(batch, rng)[0]
        results = [b.step(arrays) for b in (batch, clone, restored)]
        for other in results[1:]:
            for a, b in zip(results[0], other):
                assert np.array_equal(a, b)
        restarted += len(batch.final_infos)
    assert all(same(batch.infos(k), restored.infos(k)) for k in range(batch.n_copies))
    assert restarted > 0  # copies ended and started their next episodes


@pytest.mark.parametrize("action_type", ["velocity", "operator"])
def test_a_lone_env_copied_mid_episode_continues_bit_for_bit(action_type):
    env = teamgym.make("Exploration-v0", action_type=action_type, sensor_noise=0.002, door_resample_period=3.0)
    env.reset(seed=8)
    rng = np.random.default_rng(4)

    def actions(e):
        if action_type == "operator":
            masks = e.action_masks()
            return {a: int(rng.choice(np.flatnonzero(masks[a]))) for a in e.agents}
        return {a: rng.uniform(-0.1, 0.1, 2).astype(np.float32) for a in e.agents}

    while env.cycles <= env.rebase_cycles + 10:
        env.step(actions(env))
    assert env._log[0][0] == "base"  # re-based: copies start from the snapshot
    env.set_door("D3,6", False)
    copies = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    for _ in range(15):
        joint = actions(env)
        out = env.step(joint)
        for other in copies:
            assert all(same(a, b) for a, b in zip(other.step(joint), out))
    for other in copies:
        assert np.array_equal(other.state(), env.state())
        assert other._arrays is not env._arrays and np.shares_memory(other.model.clutter, other._arrays.clutter)


def test_the_vectorised_place_rule_is_the_lone_env_rule():
    """``ExplorationArrays.update_places`` over many copies gives the lone ``_update_state``'s rows (door sightings too)."""
    env = teamgym.make("Exploration-v0", n_robots=3)
    env.reset(seed=0)
    g, n = 40, 3
    rng = np.random.default_rng(7)
    centres = env._door_centres
    near = centres[rng.integers(len(centres), size=(g, n))] + rng.normal(0.0, 0.05, (g, n, 2))
    anywhere = rng.uniform(0.0, max(env.map.size), (g, n, 2))
    points = np.where(rng.random((g, n, 1)) < 0.6, near, anywhere)
    team = ExplorationArrays(n, env.ring.width, env.config.sensor_range, env._arrays.clutter_prior, env._arrays.door_prior, g)
    for k in range(g):
        team.start(k, rng.random(env.n_doors) < 0.5)
        team.sector[k] = rng.integers(env.n_sectors, size=n)
    lone = {name: getattr(team, name).copy() for name in team.arrays()}
    for k in range(g):
        env._use_rows(team, k)
        env.world.robot_states = np.column_stack([points[k], np.zeros((n, 4))])
        env._update_state()
    expected = {name: getattr(team, name).copy() for name in team.arrays()}
    for name, value in lone.items():
        getattr(team, name)[:] = value
    team.update_places(slice(0, g), points, env._bounds_array, env._discs_array, env.goal)
    for name in ("sector", "place", "door_belief", "visited", "explored_all", "explored_goals", "newly_explored"):
        assert np.array_equal(getattr(team, name), expected[name]), name
    assert (expected["place"] >= env.n_sectors).sum() > 10  # the door rule was exercised


def test_the_arrays_grow_shrink_and_start_copies_in_place():
    arrays = ExplorationArrays(2, 8, 0.1, np.array([0.1, 0.2, 0.3]), np.array([1.0, 0.2]), n_copies=2)
    arrays.visited[1, 2] = True
    arrays.door_belief[1, 1] = 0.0
    arrays.grow(4)
    assert arrays.visited.shape == (4, 3) and arrays.visited[1, 2] and not arrays.visited[3].any()
    assert arrays.door_belief[1].tolist() == [1.0, 0.0] and arrays.door_belief[3].tolist() == [1.0, 0.2]
    arrays.start(1, np.array([True, False]))
    assert not arrays.visited[1].any() and arrays.door_belief[1].tolist() == [1.0, 0.2]
    assert arrays.door_is_open[1].tolist() == [True, False] and (arrays.proximity[1] == 0.1).all()
    assert math.isnan(arrays.explore_time[1]) and arrays.clutter[1].tolist() == [0.1, 0.2, 0.3]
    arrays.shrink(1)
    assert arrays.n_copies == 1 and arrays.proximity.shape == (1, 2, 8) and arrays.clutter_sum.shape == (1, 3)


@pytest.mark.parametrize("action_type", ["velocity", "operator"])
def test_a_snapshot_with_the_episode_in_attributes_is_converted_on_load(action_type):
    """Snapshots of earlier releases kept the episode in ``_*`` attributes (and ``visited``, ``model``,
    ``clutter_estimate``, the watchers on the env): adopting one fills the copy's rows, bit for bit."""
    env = teamgym.make("Exploration-v0", action_type=action_type, door_resample_period=2.0)
    env.reset(seed=5)
    rng = np.random.default_rng(1)

    def actions(e):
        if action_type == "operator":
            masks = e.action_masks()
            return {a: int(rng.choice(np.flatnonzero(masks[a]))) for a in e.agents}
        return {a: rng.uniform(-0.1, 0.1, 2).astype(np.float32) for a in e.agents}

    for _ in range(8 if action_type == "operator" else 80):
        env.step(actions(env))
    clone = copy.deepcopy(env)
    state = clone._episode_state()
    rows = state.pop("_episode_rows")
    for name in rows:
        if name not in ("door_is_open", "in_stage", "clutter", "door_belief", "clutter_sum", "clutter_count", "visited"):
            state[f"_{name}"] = rows[name]
    state["_stage_robots"] = np.flatnonzero(rows["in_stage"]).tolist()
    state["visited"] = rows["visited"]
    model, estimate = copy.deepcopy(clone.model), copy.deepcopy(clone.clutter_estimate)
    model.clutter, model.door_open, estimate.ratio_sum, estimate.count = (
        rows["clutter"],
        rows["door_belief"],
        rows["clutter_sum"],
        rows["clutter_count"],
    )
    state["model"], state["clutter_estimate"] = model, estimate
    operators = clone._operators
    if operators is not None:
        state["_watchers"], state["_tasks"] = operators.watchers, operators.tasks
        operators.watchers, operators.tasks = [], None
    clone._arrays.start(clone._copy, np.zeros(clone.n_doors, dtype=bool))  # what the conversion must restore
    clone._adopt_episode_state(state)
    for _ in range(12):
        joint = actions(env)
        assert all(same(a, b) for a, b in zip(clone.step(joint), env.step(joint)))
    assert np.array_equal(clone.state(), env.state())
