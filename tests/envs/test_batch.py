"""``teamgym.make_batch``: every copy of every batch steps as the single env with its seed, bit for bit.

Every env id × action type × observation format (and a learned-message case per id): K copies
stepped with arrays against K lone envs stepped with dicts — observations (every field, masks
included), rewards, terminations, truncations and infos. Then the batch's own API: auto-reset,
pickling mid-episode, rendering one copy, and bad input refused before anything changes.
"""

from __future__ import annotations

import copy
import pickle
import typing

import numpy as np
import pytest
from gymnasium import spaces

import teamgym
from teamgym.envs.base import EpisodeOverError
from teamgym.envs.config import ConfigError
from teamgym.envs.foraging.phases import ForagingPhases
from teamgym.envs.rendezvous.phases import RendezvousPhases
from teamgym.sim import world_group
from tests.batch_lockstep import same


def batch_cases():
    cases = []
    for env_id in teamgym.envs():
        hint = typing.get_type_hints(teamgym.env_class(env_id).config_class).get("action_type")
        kinds = typing.get_args(hint) if typing.get_origin(hint) is typing.Literal else (None,)
        for kind in kinds:
            base = {"max_cycles": 30, **({"action_type": kind} if kind else {})}
            discrete = isinstance(teamgym.make(env_id, **base).action_space("robot_0"), spaces.Discrete)
            for fmt in ("flat", "dict", *(("masked",) if discrete else ())):
                cases.append(pytest.param(env_id, {**base, "obs_format": fmt}, id=f"{env_id}-{kind or 'default'}-{fmt}"))
        comm = {"max_cycles": 30, "obs_format": "dict", "comm_dim": 2, "comm_throughput": 0.5, "comm_latency": 1}
        cases.append(pytest.param(env_id, comm, id=f"{env_id}-comm"))
    # Foraging's consumed targets that stay in the cameras, a graded radio, and consumptions within 30 steps.
    persist = {"max_cycles": 30, "obs_format": "dict", "consumed_targets": "persist", "packet_rate": 2.5, "consume_time": 0.3}
    cases.append(pytest.param("Foraging-v0", {**persist, "action_type": "velocity"}, id="Foraging-v0-persist-rate"))
    return cases


def draw(space: spaces.Space, rng: np.random.Generator, mask: np.ndarray | None) -> typing.Any:
    if isinstance(space, spaces.Dict):
        return {key: draw(sub, rng, mask if key == "motion" else None) for key, sub in space.spaces.items()}
    if isinstance(space, spaces.Discrete):
        allowed = np.flatnonzero(mask) if mask is not None else np.arange(space.n)
        return int(space.start + rng.choice(allowed))
    if isinstance(space, spaces.MultiDiscrete):
        return rng.integers(space.start, space.start + space.nvec)
    return rng.uniform(space.low, space.high).astype(space.dtype)


def joint_arrays(batch, rng):
    """Actions for every row (K, N, ...) drawn within the masks, and the same actions per copy and agent."""
    masks = batch.action_masks()
    rows = [
        [draw(batch.action_space, rng, None if masks is None else masks[k, i]) for i in range(batch.n_robots)]
        for k in range(batch.n_copies)
    ]
    if isinstance(batch.action_space, spaces.Dict):
        arrays = {key: np.array([[row[key] for row in copy_rows] for copy_rows in rows]) for key in batch.action_space.spaces}
    else:
        arrays = np.array(rows)
    return arrays, rows


def row_of(observations, k: int, i: int):
    if isinstance(observations, dict):
        return {key: value[k, i] for key, value in observations.items()}
    return observations[k, i]


@pytest.mark.parametrize(("env_id", "config"), batch_cases())
def test_every_copy_steps_as_the_single_env_with_its_seed(env_id, config, monkeypatch):
    # Three copies hold fewer robots than a group needs to step its worlds together by default
    # (world_group.MIN_ROBOTS_TOGETHER); lower it so the batch takes that path from its second step.
    monkeypatch.setattr(world_group, "MIN_ROBOTS_TOGETHER", 0)
    # Likewise the groups from which Foraging and Rendezvous run their phases as passes over copies.
    monkeypatch.setattr(ForagingPhases, "min_group", 2)
    monkeypatch.setattr(RendezvousPhases, "min_group", 2)
    K = 3
    batch = teamgym.make_batch(env_id, K, **config)
    lones = [teamgym.make(env_id, **config) for _ in range(K)]
    observations = batch.reset(seed=40)
    for k, env in enumerate(lones):
        expected, _ = env.reset(seed=40 + k)
        for agent, value in expected.items():
            assert same(row_of(observations, k, env._row[agent]), value), (k, agent)
    rng = np.random.default_rng(1)
    steps = 0
    while not batch.episode_over().all() and steps < 30:
        arrays, rows = joint_arrays(batch, rng)
        observations, rewards, terminated, truncated = batch.step(arrays)
        for k, env in enumerate(lones):
            if not env.agents:
                assert not batch.active[k].any()
                continue
            step = env.step({agent: rows[k][env._row[agent]] for agent in env.agents})
            infos = batch.infos(k)
            for agent, value in step[0].items():
                i = env._row[agent]
                assert same(row_of(observations, k, i), value), (steps, k, agent)
                assert (
                    step[1][agent] == rewards[k, i] and step[2][agent] == terminated[k, i] and step[3][agent] == truncated[k, i]
                )
                assert same(infos[agent], step[4][agent]), (steps, k, agent)
            assert [a for a in batch.possible_agents if batch.active[k, env._row[a]]] == env.agents
        steps += 1
    assert steps > 0


def test_auto_reset_starts_the_next_episode_with_the_copy_stream():
    batch = teamgym.make_batch("Navigation-v0", 2, auto_reset=True, n_robots=2, max_cycles=5)
    lone = teamgym.make("Navigation-v0", n_robots=2, max_cycles=5)
    batch.reset(seed=3)
    lone.reset(seed=4)  # copy 1
    actions = np.zeros((2, 2, 2), np.float32)
    for _ in range(5):
        observations, _, _, truncated = batch.step(actions)
        final = lone.step({a: actions[1, 0] for a in lone.agents})
    assert truncated.all() and set(batch.final_observations) == {0, 1}
    assert np.array_equal(batch.final_observations[1][0], final[0]["robot_0"])
    assert batch.final_infos[1]["robot_0"]["success"] is False
    fresh, _ = lone.reset()  # no seed: the copy's own stream goes on
    assert batch.active.all() and np.array_equal(observations[1, 0], fresh["robot_0"])


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_batch_continues_identically_after_pickling(how):
    batch = teamgym.make_batch("BoxPushing-v0", 2, max_cycles=40)
    batch.reset(seed=8)
    rng = np.random.default_rng(0)
    for _ in range(10):
        batch.step(joint_arrays(batch, rng)[0])
    clone = pickle.loads(pickle.dumps(batch)) if how == "pickle" else copy.deepcopy(batch)
    for _ in range(10):
        arrays, _ = joint_arrays(batch, rng)
        a, b = batch.step(arrays), clone.step(arrays)
        for x, y in zip(a, b):
            assert np.array_equal(x, y)


def test_masked_batch_refuses_an_inadmissible_action_and_changes_nothing():
    batch = teamgym.make_batch("Rendezvous-v0", 2)
    batch.reset(seed=0)
    masks = batch.action_masks()
    assert masks.shape[:2] == (2, 2) and masks.dtype == np.int8
    actions = np.array([[int(np.flatnonzero(masks[k, i])[0]) for i in range(2)] for k in range(2)])
    blocked = np.flatnonzero(masks[1, 0] == 0)
    assert len(blocked), "the first state has a masked action"
    bad = actions.copy()
    bad[1, 0] = blocked[0]
    before = pickle.dumps(batch)
    with pytest.raises(ValueError, match="is masked"):
        batch.step(bad)
    assert pickle.dumps(batch) == before


@pytest.mark.parametrize(
    ("actions", "error", "match"),
    [
        (np.zeros((2, 2)), ValueError, "shape"),
        (np.full((2, 2, 2), np.nan), ValueError, "robot_0"),
        (np.full((2, 2, 2), 1e9), ValueError, "robot_0"),
    ],
)
def test_bad_actions_are_refused_before_anything_changes(actions, error, match):
    batch = teamgym.make_batch("Navigation-v0", 2, n_robots=2)
    batch.reset(seed=1)
    before = pickle.dumps(batch)
    with pytest.raises(error, match=match):
        batch.step(actions)
    assert pickle.dumps(batch) == before


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"n_copies": 0}, ValueError, "n_copies"),
        ({"n_copies": 2.5}, ValueError, "n_copies"),
        ({"n_copies": 2, "auto_reset": "yes"}, TypeError, "auto_reset"),
        ({"n_copies": 2, "render_mode": "human"}, ValueError, "render_mode"),
        ({"n_copies": 2, "fixed_agents": True}, ConfigError, "fixed_agents"),
        ({"n_copies": 2, "n_robots": 0}, ConfigError, "n_robots"),
    ],
)
def test_invalid_batches_are_refused(kwargs, error, match):
    with pytest.raises(error, match=match):
        teamgym.make_batch("Navigation-v0", **kwargs)


def test_stepping_without_reset_or_after_the_end_is_refused():
    batch = teamgym.make_batch("Exploration-v0", 2, max_cycles=2)
    with pytest.raises(EpisodeOverError, match="never reset"):
        batch.step(np.zeros((2, 3, 2)))
    batch.reset(seed=0)
    batch.step(np.zeros((2, 3, 2)))
    batch.step(np.zeros((2, 3, 2)))
    with pytest.raises(EpisodeOverError, match="no active robot"):
        batch.step(np.zeros((2, 3, 2)))
    with pytest.raises(IndexError, match="copy 5"):
        batch.reset_copy(5)


def test_render_draws_the_chosen_copy():
    batch = teamgym.make_batch("Navigation-v0", 2, render_mode="rgb_array", trails=True, n_robots=2)
    batch.reset(seed=0)
    batch.step(np.ones((2, 2, 2), np.float32) * 0.05)
    frames = [batch.render(k) for k in range(2)]
    assert frames[0].ndim == 3 and frames[0].shape == frames[1].shape and not np.array_equal(frames[0], frames[1])
    assert len(batch.copies[0].trajectories()["robot_0"]) == 2
