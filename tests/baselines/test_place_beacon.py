"""``place-beacon`` (baselines/rendezvous/place_beacon.py): a rendezvous over the learned-message channel."""

import numpy as np
import pytest

import teamgym
from baselines import make_policy
from baselines.evaluate import evaluate
from baselines.rendezvous.place_beacon import MESSAGE_SIZE, grid_codes

TASK = {"block_rate": 0.096, "comm_throughput": 0.5}


def test_every_place_of_the_paper_map_has_its_own_cell_near_its_position():
    env = teamgym.make("Rendezvous-v0", comm_dim=MESSAGE_SIZE).unwrapped
    codes = grid_codes(env.places_xy, 9)
    assert len(np.unique(codes, axis=0)) == len(codes) == 38
    assert np.all(np.isin(np.round(codes * 4), np.arange(-4, 5)))  # values on the 9-level grid
    xy = np.asarray(env.places_xy)
    unit = 2 * (xy - xy.min(axis=0)) / (xy.max(axis=0) - xy.min(axis=0)) - 1
    assert np.max(np.abs(codes - unit)) < 0.5  # within two cells of where the place is


def test_grid_too_small_for_the_places_is_refused():
    with pytest.raises(ValueError, match="do not fit a 2 x 2 message grid"):
        grid_codes(np.random.default_rng(0).random((5, 2)), 2)


def test_a_heard_message_names_the_place_it_was_sent_for():
    env = teamgym.make("Rendezvous-v0", comm_dim=MESSAGE_SIZE)
    policy = make_policy("place-beacon", env.unwrapped)
    for place in range(38):
        message = policy.message(place, heard=place % 2 == 0)
        assert policy.place_of(message) == place and message[2] == (1.0 if place % 2 == 0 else -1.0)


def test_it_needs_three_message_values_and_next_place_actions():
    with pytest.raises(ValueError, match="comm_dim=3"):
        make_policy("place-beacon", teamgym.make("Rendezvous-v0", comm_dim=2).unwrapped)
    with pytest.raises(ValueError, match="ack_stages must be an integer >= 0"):
        make_policy("place-beacon", teamgym.make("Rendezvous-v0", comm_dim=3).unwrapped, ack_stages=-1)


def test_robots_wait_until_they_know_they_heard_each_other_then_walk():
    env = teamgym.make("Rendezvous-v0", comm_dim=MESSAGE_SIZE, comm_throughput=1.0, start_places=("1", "38"))
    policy = make_policy("place-beacon", env.unwrapped)
    observations, infos = env.reset(seed=0)
    policy.reset(0)
    first = policy.act(observations, infos)
    wait = env.unwrapped.max_degree
    assert all(action["motion"] == wait and action["message"][2] == -1.0 for action in first.values())
    observations, _, _, _, infos = env.step(first)  # every message arrives: both have heard, but not that they were heard
    second = policy.act(observations, infos)  # one stage (ack_stages=1) more to tell the mate
    assert all(action["motion"] == wait and action["message"][2] == 1.0 for action in second.values())
    observations, _, _, _, infos = env.step(second)
    third = policy.act(observations, infos)
    assert all(action["motion"] != wait and action["message"][2] == 1.0 for action in third.values())


def test_the_team_meets_with_the_channel_and_never_without_it():
    """Half the messages lost: every episode meets; the channel cut: no robot ever hears, none moves."""
    lossy = evaluate("Rendezvous-v0", "place-beacon", 6, 52000, {**TASK, "comm_dim": MESSAGE_SIZE})
    assert all(r.success for r in lossy)
    assert np.mean([r.metrics["robot_0"]["meeting_time"] for r in lossy]) < 60
    silent = {**TASK, "comm_dim": MESSAGE_SIZE, "comm_throughput": 0.0, "max_cycles": 300}
    cut = evaluate("Rendezvous-v0", "place-beacon", 2, 52000, silent)
    assert not any(r.success for r in cut)
    assert all(m["path_length"] == 0.0 for r in cut for m in r.metrics.values())
