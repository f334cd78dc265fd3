"""Foraging-v0 (paper 002): ``consumed_targets`` ("vanish" | "persist") and ``packet_rate`` (packets per second)."""

import math

import numpy as np
import pytest

import teamgym
from teamgym.envs.config import ConfigError
from teamgym.envs.foraging.env import packet_due
from teamgym.envs.foraging.perception import SENDER, TARGET

EXACT = {"vision_noise": 0.0, "odometry_rotation_noise": 0.0, "odometry_distance_noise": 0.0}
SCENE = {"targets": [(1.0, 1.0), (2.5, 2.0)], "starts": [(1.08, 1.0, math.pi), (2.8, 0.3, 0.0)]}


def velocity_env(**config):
    return teamgym.make("Foraging-v0", action_type="velocity", n_robots=2, n_targets=2, consume_time=1.0, **EXACT, **config)


def still(env):
    return {a: np.zeros(2, dtype=np.float32) for a in env.agents}


def sit(env, steps):
    for _ in range(steps):
        obs, rewards, _, _, infos = env.step(still(env))
    return obs, rewards, infos


def test_defaults_are_todays_radio_and_vanishing_targets():
    c = teamgym.make("Foraging-v0").config
    assert c.consumed_targets == "vanish" and c.packet_rate is None


def test_vanish_removes_a_consumed_target_from_the_world_and_the_camera():
    env = velocity_env()
    obs, _ = env.reset(seed=0, options=SCENE)
    assert env.decode(obs["robot_0"])["detection_mask"].sum() == 1  # robot_0 looks at the target at its feet
    obs, _, infos = sit(env, 10)
    assert infos["robot_0"]["targets_done"] == 1 and "target_0" not in env.world.entities
    fields = env.decode(obs["robot_0"])
    assert fields["detection_mask"].sum() == 0 and fields["at_target"][0] == 0 and "redundant" not in infos["robot_0"]


def test_persist_keeps_a_consumed_target_in_the_world_and_the_camera_as_a_target():
    env = velocity_env(consumed_targets="persist")
    env.reset(seed=0, options=SCENE)
    obs, rewards, infos = sit(env, 10)
    assert infos["robot_0"]["targets_done"] == 1 and infos["robot_0"]["TT1"] == pytest.approx(1.0)
    assert rewards["robot_0"] > 0.9 and env.state()[6 + 2] == 0.0  # consumed (state: live 0) ...
    assert "target_0" in env.world.entities  # ... but still there
    for _ in range(3):
        fields = env.decode(obs["robot_0"])
        rows = fields["detections"][fields["detection_mask"] == 1]
        assert rows[:, 0].tolist() == [TARGET] and rows[0, 1:3].tolist() == [5, 5]  # seen as any target
        assert fields["at_target"][0] == 1 and fields["consume_progress"][0] == 1.0  # the robot's own operation: done
        packet = env.decode(obs["robot_1"])
        assert packet["received"][packet["received_mask"] == 1][:, 0].tolist() == [SENDER, TARGET]  # and on the radio
        obs, rewards, infos = sit(env, 1)
        assert rewards["robot_0"] < 0 and infos["robot_0"]["targets_done"] == 1 and infos["robot_0"]["redundant"] == 0


def test_persist_a_consumed_target_cannot_be_consumed_again_a_second_operation_is_redundant():
    env = velocity_env(consumed_targets="persist")
    env.reset(seed=0, options=SCENE)
    sit(env, 10)  # robot_0 consumes target 0
    drive = {"robot_1": np.zeros(2, dtype=np.float32)}
    for v in (-0.5, 0.5):  # back off out of reach (robot_0 faces the target) and return
        for _ in range(5):
            obs, *_ = env.step({**drive, "robot_0": np.array([v, 0.0], dtype=np.float32)})
            if v < 0:
                left = env.decode(obs["robot_0"])["at_target"][0] == 0
    assert left and env.decode(obs["robot_0"])["at_target"][0] == 1
    obs, rewards, infos = sit(env, 10)  # a second operation of consume_time at the consumed target
    fields = env.decode(obs["robot_0"])
    assert fields["consume_progress"][0] == 1.0 and rewards["robot_0"] < 0
    assert infos["robot_0"]["targets_done"] == 1 and infos["robot_0"]["redundant"] == 1 and infos["robot_1"]["redundant"] == 0
    assert not infos["robot_0"]["success"]
    *_, infos = sit(env, 10)  # staying on is no further operation
    assert infos["robot_0"]["redundant"] == 1


def test_persist_surround_counts_a_target_once():
    config = dict(task="surround", n_robots=2, n_targets=2, robots_per_target=2, consumed_targets="persist", **EXACT)
    env = teamgym.make("Foraging-v0", action_type="velocity", **config)
    env.reset(seed=0, options={"targets": [(1.0, 1.0), (2.5, 2.0)], "starts": [(1.15, 1.0, 0.0), (0.85, 1.0, 0.0)]})
    for _ in range(5):
        *_, infos = env.step(still(env))
    assert infos["robot_0"]["targets_done"] == 1 and not infos["robot_0"]["success"]


def test_packet_due_sends_at_the_steps_where_the_rate_steps_up():
    assert [packet_due(k, 1.0) for k in range(4)] == [True] * 4
    assert not any(packet_due(k, 0.0) for k in range(50))
    assert [k for k in range(12) if packet_due(k, 0.25)] == [0, 4, 8]
    assert sum(packet_due(k, 0.01) for k in range(1000)) == 10  # 0.1 packets/s at dt 0.1: 10 in 100 s


@pytest.mark.parametrize(("rate", "sent"), [(0.0, 0), (0.5, 3), (2.5, 13), (10.0, 51)])
def test_packet_rate_is_packets_per_second(rate, sent):
    env = teamgym.make("Foraging-v0", packet_rate=rate, time_limit=100.0)
    obs, infos = env.reset(seed=1)
    received = int(env.decode(obs["robot_0"])["received_mask"][0])
    for _ in range(50):  # 5 s after the reset's sensing phase
        obs, _, _, _, infos = env.step({a: 0 for a in env.agents})
        received += int(env.decode(obs["robot_0"])["received_mask"][0])
    assert infos["robot_1"]["messages_sent"] == sent and received == sent  # comm_throughput 1: all arrive


def test_packet_rate_of_one_per_control_step_is_todays_radio():
    a = teamgym.make("Foraging-v0", comm_throughput=0.5)
    b = teamgym.make("Foraging-v0", comm_throughput=0.5, packet_rate=10.0)
    obs_a, _ = a.reset(seed=5)
    obs_b, _ = b.reset(seed=5)
    for step in range(60):
        assert all(np.array_equal(obs_a[k], obs_b[k]) for k in obs_a), step
        actions = {agent: (7 * step + i) % a.grid.n_cells for i, agent in enumerate(a.agents)}
        obs_a, *_ = a.step(actions)
        obs_b, *_ = b.step(actions)


@pytest.mark.parametrize(
    ("config", "key"),
    [
        ({"consumed_targets": "keep"}, "consumed_targets"),
        ({"packet_rate": -1.0}, "packet_rate"),
        ({"packet_rate": "fast"}, "packet_rate"),
        ({"packet_rate": 20.0}, "packet_rate"),  # more than one per control step (dt 0.1)
        ({"packet_rate": 6.0, "dt": 0.2, "substeps": 20}, "packet_rate"),  # at most 5 per s at dt 0.2
    ],
)
def test_invalid_radio_and_consumed_settings_are_one_line_errors_naming_the_key(config, key):
    with pytest.raises(ConfigError, match=key) as error:
        teamgym.make("Foraging-v0", **config)
    assert "\n" not in str(error.value)
