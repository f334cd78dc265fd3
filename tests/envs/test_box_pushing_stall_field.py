"""``observe_stall=True``: BoxPushing's ``stall`` field counts the robot's consecutive stalled cycles."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import teamgym
from teamgym.envs.box_pushing.env import STALL_CAP

S1 = {"situation": "S1", "action_type": "wheels", "max_cycles": 400}


def test_default_layout_has_no_stall_field():
    env = teamgym.make("BoxPushing-v0", **S1)
    assert "stall" not in env.layout.slices
    assert env.observation_space("robot_0").shape == (21,)


def drive(env, action, steps):
    """``steps`` steps of one wheel action; the ``stall`` readings and the env's slip of each."""
    readings, slips = [], []
    for _ in range(steps):
        obs, *_ = env.step({"robot_0": np.asarray(action, np.float32)})
        readings.append(float(env.decode(obs["robot_0"])["stall"][0]))
        slips.append(env.robots["robot_0"].encoders.slip)
    return readings, slips


def test_stall_counts_consecutive_stalled_cycles_and_resets():
    env = teamgym.make("BoxPushing-v0", **S1, observe_stall=True)
    obs, _ = env.reset(seed=0)
    assert env.observation_space("robot_0").shape == (22,)
    assert env.decode(obs["robot_0"])["stall"][0] == 0.0
    # Full speed ahead until the robot has been pressing against something for long enough.
    readings, slips = drive(env, [0.4, 0.4], 300)
    run, expected = 0, []
    for slip in slips:
        run = run + 1 if slip > 0.9 else 0
        expected.append(min(run, STALL_CAP) / STALL_CAP)
    assert readings == pytest.approx(expected)
    assert max(readings) == 1.0  # it did stall for STALL_CAP cycles in a row
    # Backing off frees the wheels: the count drops to zero at once.
    readings, slips = drive(env, [-0.4, -0.4], 5)
    assert slips[-1] < 0.9 and readings[-1] == 0.0


def test_stall_field_is_bounded_and_survives_copies():
    env = teamgym.make("BoxPushing-v0", **S1, observe_stall=True, obs_format="dict")
    obs, _ = env.reset(seed=1)
    space = env.observation_space("robot_0")
    assert space["stall"].low[0] == 0.0 and space["stall"].high[0] == 1.0
    for _ in range(120):
        obs, *_ = env.step({"robot_0": np.full(2, 0.4, np.float32)})
    assert space.contains(obs["robot_0"])
    twin, clone = pickle.loads(pickle.dumps(env)), copy.deepcopy(env)
    action = {"robot_0": np.full(2, 0.4, np.float32)}
    a, b, c = env.step(action)[0], twin.step(action)[0], clone.step(action)[0]
    assert a["robot_0"]["stall"] == b["robot_0"]["stall"] == c["robot_0"]["stall"]


@pytest.mark.parametrize("obs_format", ["flat", "dict"])
def test_pettingzoo_api_with_the_stall_field(obs_format):
    from pettingzoo.test import parallel_api_test

    parallel_api_test(teamgym.make("BoxPushing-v0", situation="S2", observe_stall=True, obs_format=obs_format), num_cycles=40)
