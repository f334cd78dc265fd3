"""The ``sbs-oracle`` diagnostic: robots recognized from the simulator's state (baselines/box_pushing/oracle.py)."""

import math

import numpy as np
import pytest

import teamgym
from baselines.box_pushing.oracle import TrueRobotBearings
from baselines.box_pushing.recognizer import RecognizerParams, SituationRecognizer
from baselines.registry import make_policy
from teamgym.sim.sensors import KHEPERA_RING

FREE = np.full(8, 0.1)
LAMP_AHEAD = np.array([0.2, 0.5, 1.0, 1.0, 0.5, 0.2, 0.0, 0.0])
STILL = np.zeros(4)


def two_robots(gap: float):
    """Two robots on the table's middle line, robot_0 facing robot_1 ``gap`` m away (body to body)."""
    env = teamgym.make("BoxPushing-v0", n_robots=2, n_light_boxes=1, n_heavy_boxes=0)
    env.reset(seed=0)
    radius = env.spec_robot.radius
    env.robots["robot_0"].teleport((0.3, 0.45), 0.0)
    env.robots["robot_1"].teleport((0.3 + 2 * radius + gap, 0.45), math.pi / 2)
    return env


def step_robot(env, agent: str, dx: float) -> None:
    x, y, heading = env.robots[agent].pose
    env.robots[agent].teleport((x + dx, y), heading)


def test_a_moving_robot_in_range_is_seen_at_its_bearing():
    env = two_robots(gap=0.05)
    oracle = TrueRobotBearings(sensor_range=0.1, change_threshold=0.004, patience=3)
    for _ in range(4):
        oracle.update(env)  # both still: after the patience neither counts as moving
    assert oracle.update(env) == {"robot_0": [], "robot_1": []}
    step_robot(env, "robot_1", 0.01)
    bearings = oracle.update(env)
    assert bearings["robot_0"] == [pytest.approx(0.0, abs=1e-9)]  # straight ahead of robot_0
    assert bearings["robot_1"] == []  # robot_0 did not move
    # robot_1 faces +y, so robot_0 (towards -x) is on its left-hand side at +90°... seen once robot_0 moves
    step_robot(env, "robot_0", 0.005)
    assert oracle.update(env)["robot_1"] == [pytest.approx(math.pi / 2, abs=1e-9)]


def test_a_robot_beyond_sensor_range_is_not_seen():
    env = two_robots(gap=0.15)
    oracle = TrueRobotBearings(sensor_range=0.1, change_threshold=0.004, patience=3)
    for _ in range(5):
        step_robot(env, "robot_1", 0.01)
        assert oracle.update(env)["robot_0"] == []


def test_true_robots_drive_the_robot_facts_and_m():
    params = RecognizerParams(ray_angles=tuple(KHEPERA_RING.tolist()), look_cycles=0)
    recognizer = SituationRecognizer(params)
    facts = recognizer.update(FREE, LAMP_AHEAD, STILL, robots=[])
    assert not recognizer.m and not any("robot" in fact for fact in facts)
    facts = recognizer.update(FREE, LAMP_AHEAD, STILL, robots=[0.1])
    assert "forward-robot" in facts and recognizer.m
    facts = recognizer.update(FREE, LAMP_AHEAD, STILL, robots=[])
    assert "forward-robot" not in facts and "forward-robot-leaving" in facts
    facts = recognizer.update(FREE, LAMP_AHEAD, STILL, robots=[math.pi])
    assert "back-robot" in facts and "forward-robot-leaving" in facts


def test_sbs_oracle_is_registered_and_reproducible():
    def run(seed: int) -> list[tuple[int, ...]]:
        env = teamgym.make("BoxPushing-v0", situation="S3", max_cycles=300)
        policy = make_policy("sbs-oracle", env, fixed_sbs=3)
        observations, infos = env.reset(seed=seed)
        policy.reset(seed)
        trace = []
        while env.agents:
            actions = policy.act({a: observations[a] for a in env.agents}, infos)
            trace.append(tuple(actions[a] for a in sorted(actions)))
            observations, _, _, _, infos = env.step(actions)
        return trace, policy

    first, policy = run(3)
    second, _ = run(3)
    assert first == second
    assert sum(policy.activations[k] for k in range(10, 20)) > 0  # swarm rules fire on recognized robots


def test_unknown_recognition_is_refused():
    env = teamgym.make("BoxPushing-v0", situation="S1")
    with pytest.raises(ValueError, match="recognition"):
        make_policy("sbs", env, recognition="telepathy")
