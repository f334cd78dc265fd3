"""The ``cooperative-push`` baseline (issue 14, part 3): lamp bearing, decisions, pushing, no trick in S4."""

import math
from dataclasses import replace

import numpy as np
import pytest

import teamgym
from baselines.box_pushing.cooperative import (
    CIRCLE,
    EXPLORE,
    FACE,
    SIDESTEP,
    WAIT,
    CooperativePush,
    PushController,
    PushParams,
    lamp_bearing,
)
from baselines.registry import make_policy, policies, required_config
from teamgym.sim import KHEPERA_RING

SPEC_RADIUS = 0.0275


@pytest.mark.parametrize("phi", np.deg2rad([0.0, 27.0, -63.0, 100.0, 178.0]))
def test_lamp_bearing_from_eight_noisy_sensors(phi):
    rng = np.random.default_rng(0)
    errors = []
    for _ in range(200):
        gains = np.exp(rng.normal(0.0, 0.2, 8))
        light = 5.0 * np.maximum(np.cos(phi - KHEPERA_RING), 0.0) * gains * (1 + rng.normal(0.0, 0.1, 8))
        bearing, amplitude = lamp_bearing(light, KHEPERA_RING)
        errors.append(math.remainder(bearing - phi, 2 * math.pi))
        assert 2.5 < amplitude < 10.0
    assert abs(np.mean(errors)) < math.radians(6) and np.std(errors) < math.radians(15)
    exact, amplitude = lamp_bearing(5.0 * np.maximum(np.cos(phi - KHEPERA_RING), 0.0), KHEPERA_RING)
    assert exact == pytest.approx(math.remainder(phi, 2 * math.pi), abs=math.radians(1)) and amplitude == pytest.approx(
        5.0, rel=0.01
    )


def test_registered_for_both_versions_with_wheel_actions():
    assert "cooperative-push" in policies() and required_config("cooperative-push") == {"action_type": "wheels"}
    for env_id in ("BoxPushing-v0", "BoxPushing-v1"):
        policy = make_policy("cooperative-push", teamgym.make(env_id, action_type="wheels"))
        assert isinstance(policy, CooperativePush)
    with pytest.raises(TypeError, match="wheels"):
        make_policy("cooperative-push", teamgym.make("BoxPushing-v1"))
    with pytest.raises(TypeError, match="unknown cooperative-push parameter"):
        make_policy("cooperative-push", teamgym.make("BoxPushing-v1", action_type="wheels"), speed=1.0)


def controller(seed=0):
    return PushController(PushParams(), KHEPERA_RING, 0.053, 0.008, 0.1, 0.1, 0.4, np.random.default_rng(seed))


def lamp_at(phi, amplitude=3.0):
    return amplitude * np.maximum(np.cos(phi - KHEPERA_RING), 0.0)


FREE = np.full(8, 0.1)
IDLE = np.zeros(4)


def test_an_object_towards_the_lamp_is_pushed_and_one_elsewhere_is_circled_on_the_lamps_side():
    ahead = FREE.copy()
    ahead[2] = ahead[3] = 0.02
    c = controller()
    c.step(ahead, lamp_at(math.radians(10)), IDLE)
    assert c.state == FACE
    for phi, side in ((math.radians(80), 1.0), (math.radians(-120), -1.0)):
        c = controller()
        c.step(ahead, lamp_at(phi), IDLE)
        assert c.state == CIRCLE and c.side == side  # keep the object on the lamp's side


def test_a_stall_on_an_unmoved_object_waits_and_a_stall_at_the_goal_leaves():
    touching = FREE.copy()
    touching[1:5] = (0.01, 0.0, 0.0, 0.01)
    stalled = np.array([1.0, 1.0, 0.0, 0.0])  # commanded wheel rotation, none happened
    for amplitude, expected in ((3.0, WAIT), (40.0, "backoff")):
        c = controller()
        c._start_push()
        for _ in range(5):
            c.step(touching, lamp_at(0.0, amplitude), stalled)
        assert c.state == expected
    c = controller()
    c._start_push()
    for _ in range(round(PushParams().shove_unmoved / 0.1) + 10):
        left, right = c.step(touching, lamp_at(0.0), stalled)
        if c.state == WAIT:
            assert left > 0 and right > 0  # both wheels push forward while waiting
    assert c.state != WAIT  # waited shove_unmoved, then shoved and left


def _placed(env_id, heavy, robots, seed=0, **config):
    """A box at (0.45, 0.45) and robots just behind it on the far side from the lamp, controllers pushing."""
    env = teamgym.make(
        env_id,
        n_robots=len(robots),
        n_light_boxes=0 if heavy else 1,
        n_heavy_boxes=1 if heavy else 0,
        action_type="wheels",
        **config,
    )
    policy = make_policy("cooperative-push", env)
    env.reset(seed=seed)
    policy.reset(seed)
    box = env.world[env.box_names()[0]]
    box.teleport((0.45, 0.45), 0.0)
    for agent, dy in zip(env.agents, robots):
        env.robots[agent].teleport((0.45 - box.size[0] / 2 - SPEC_RADIUS - 0.004, 0.45 + dy), 0.0)
    env.world.read_states()
    env._read_sensors(env.agents)
    for agent in env.agents:
        policy._controller(agent)._start_push()
    return env, policy, box


def run(env, policy, steps):
    observations, infos = env._collect_observations(), {}
    for _ in range(steps):
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(policy.act(observations, infos))


def test_one_robot_pushes_a_light_box_to_the_goal_wall():
    env, policy, box = _placed("BoxPushing-v1", False, [0.01], max_cycles=400)
    run(env, policy, 400)
    assert env.episode_success() and env.cycles < 200


def test_two_robots_push_the_heavy_box_to_the_goal_wall():
    env, policy, box = _placed("BoxPushing-v1", True, [-0.035, 0.035], max_cycles=600)
    run(env, policy, 600)
    assert env.episode_success()


def test_one_robot_waits_at_the_heavy_box_and_cannot_move_it():
    """S4 has no trick: a lone robot pushes the heavy box with all its force and the box stays."""
    env, policy, box = _placed("BoxPushing-v1", True, [0.0], max_cycles=400)
    start = np.array(box.position)
    run(env, policy, 200)  # 20 s: less than shove_unmoved, the robot is still on the box, waiting for help
    assert policy.controllers["robot_0"].state in (WAIT, SIDESTEP)
    run(env, policy, 100)
    assert np.hypot(*(np.array(box.position) - start)) < 0.01 and not env.episode_success()


def test_robots_act_on_their_own_streams_and_states():
    env = teamgym.make("BoxPushing-v1", situation="S3", action_type="wheels", max_cycles=30)
    policy = make_policy("cooperative-push", env)
    observations, infos = env.reset(seed=3)
    policy.reset(3)
    first = policy.act(observations, infos)
    policy.reset(3)
    assert all(np.array_equal(first[a], b) for a, b in policy.act(observations, infos).items())
    assert set(policy.controllers) == set(env.agents) and all(
        c.state in (EXPLORE, FACE, CIRCLE) for c in policy.controllers.values()
    )
    assert sum(policy.state_steps().values()) == len(env.agents)  # reset starts every robot afresh


@pytest.mark.parametrize("hold", [True, False])
def test_a_push_holds_its_direction_by_odometry_while_the_lamps_bearing_drifts(hold):
    """``hold_heading``: a box pushed straight reaches the goal wall beside the lamp, not at its point."""
    ahead = FREE.copy()
    ahead[2] = ahead[3] = 0.005
    moving = np.array([1.0, 1.0, 1.0, 1.0])  # both wheels turned as commanded: no stall, no rotation
    c = PushController(
        replace(PushParams(), aim_spread=0.0, hold_heading=hold),
        KHEPERA_RING,
        0.053,
        0.008,
        0.1,
        0.1,
        0.4,
        np.random.default_rng(0),
    )
    c._start_push()
    left, right = c.step(ahead, lamp_at(0.0), moving)
    assert left == pytest.approx(right)
    left, right = c.step(ahead, lamp_at(math.radians(20)), moving)  # the robot slid sideways: the lamp now 20° left
    if hold:
        assert left == pytest.approx(right)  # keeps straight on
    else:
        assert abs(right - left) > 0.1 * (left + right)  # steers after the lamp's line
