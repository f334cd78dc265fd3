"""Rendezvous batches over the paths a short default episode does not reach, copy by copy against lone envs.

Ten copies at once (goals and rewards over the group in numpy, ``RendezvousPhases``),
meetings and their bonus, three robots (the mean over pairs), noisy rings, scheduled and random
blockings (obstacles waiting for a way to clear, ways detected), ``stage_end="all"``,
protocol messages, auto-reset, and pickling mid-episode: every copy's observations, rewards,
terminations, truncations and infos equal a lone env's with its seed and actions, bit for bit.
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import teamgym
from teamgym.envs.rendezvous.state import RendezvousArrays
from tests.batch_lockstep import same

CONFIGS = {
    "meetings": {"map": "square4", "max_cycles": 4000},
    "three-noisy-blockings": {
        "map": "square4",
        "n_robots": 3,
        "sensor_noise": 0.01,
        "blockings": (("A", "B", 2.0), ("B", "C", 4.0)),
        "block_rate": 0.05,
        "max_cycles": 600,
    },
    "all-arrive": {"map": "square4", "stage_end": "all", "max_cycles": 1500},
    "messages": {"map": "square4", "protocol_messages": True, "message_len": 16, "max_cycles": 2000},
}


def moves(batch, rng) -> tuple[object, list[list[object]]]:
    """Random admissible moves per copy and robot (with a record naming the next place when messages are on)."""
    masks = batch.action_masks()
    slots = np.array([[rng.choice(np.flatnonzero(m)) for m in rows] for rows in masks])
    if batch.config.protocol_messages:
        message = np.full((*slots.shape, batch.config.message_len), -1, dtype=np.int32)
        message[..., :3] = (4, 1, 0)
        message[..., 2] = slots
        per_copy = [[{"move": int(s), "message": message[k, i]} for i, s in enumerate(row)] for k, row in enumerate(slots)]
        return {"move": slots, "message": message}, per_copy
    return slots, [[int(s) for s in row] for row in slots]


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_every_copy_of_a_blocked_batch_steps_as_its_lone_env(name):
    config, K = CONFIGS[name], 10
    batch = teamgym.make_batch("Rendezvous-v0", K, **config)
    lones = [teamgym.make("Rendezvous-v0", **config) for _ in range(K)]
    batch.reset(seed=5)
    for k, env in enumerate(lones):
        env.reset(seed=5 + k)
    rng, met = np.random.default_rng(2), 0
    for _ in range(60):
        if batch.episode_over().all():
            break
        arrays, rows = moves(batch, rng)
        observations, rewards, terminated, truncated = batch.step(arrays)
        for k, env in enumerate(lones):
            if not env.agents:
                continue
            obs, rew, term, trunc, infos = env.step({a: rows[k][env._row[a]] for a in env.agents})
            for agent in obs:
                i = env._row[agent]
                assert np.array_equal(observations[k, i], obs[agent]), (k, agent)
                assert (rewards[k, i], terminated[k, i], truncated[k, i]) == (rew[agent], term[agent], trunc[agent])
            assert same(batch.infos(k), infos)
            met += any(term.values())
    if name == "three-noisy-blockings":  # obstacles were put in place, and robots found blocked ways
        team = batch.copies[0]._arrays
        assert team.placed.any() and team.known.any()
    else:
        assert met > 0  # the episodes reach the meeting (and its bonus)


def test_auto_reset_and_pickling_keep_every_copy_on_its_lone_course():
    config = CONFIGS["three-noisy-blockings"]
    batch = teamgym.make_batch("Rendezvous-v0", 9, auto_reset=True, **config)
    batch.reset(seed=1)
    rng, restarted = np.random.default_rng(0), 0
    for _ in range(12):
        batch.step(moves(batch, rng)[0])
        restarted += len(batch.final_infos)
    clone, restored = copy.deepcopy(batch), pickle.loads(pickle.dumps(batch))
    for _ in range(8):
        arrays = moves(batch, rng)[0]
        results = [b.step(arrays) for b in (batch, clone, restored)]
        for other in results[1:]:
            for a, b in zip(results[0], other):
                assert np.array_equal(a, b)
        restarted += len(batch.final_infos)
    assert all(same(batch.infos(k), restored.infos(k)) for k in range(batch.n_copies))
    assert restarted > 0  # copies ended and started their next episodes


def test_the_arrays_grow_shrink_and_start_copies_in_place():
    arrays = RendezvousArrays(n_robots=2, n_places=4, n_ways=5, ring_width=8, sensor_range=0.1, n_copies=2)
    arrays.block(1, 3)
    arrays.plans[1].append(1.5)
    arrays.grow(4)
    assert arrays.blocked.shape == (4, 5) and arrays.blocked[1, 3] and arrays.plans[1] == [1.5] and arrays.plans[3] == []
    arrays.start(1, np.array([0, 2]), [("A", "B", 1.0)])
    assert not arrays.blocked[1].any() and arrays.plans[1] == [] and arrays.pending[1] == [("A", "B", 1.0)]
    assert arrays.place[1].tolist() == [0, 2] and (arrays.target[1] == -1).all() and (arrays.proximity[1] == 0.1).all()
    arrays.shrink(1)
    assert arrays.n_copies == 1 and arrays.known.shape == (1, 2, 5) and len(arrays.pending) == 1
