"""Sensor and motor noise (issue 14, part 2): statistics of each kind, and zero noise is the exact model.

Statistical bounds: with n independent draws, a sample mean lies within 5 standard errors and a
sample standard deviation within 5·σ/√(2n) of the truth except with probability < 1e-6.
"""

import math

import numpy as np
import pytest

import teamgym
from teamgym.control.primitives import Primitive
from teamgym.envs.box_pushing.config import KHEPERA_ENCODER_RESOLUTION, BoxPushingV1Config
from teamgym.sim import DiffDriveRobot, LightSensor, ProximityRing, SensorSuite, Wall, WheelEncoders, World
from teamgym.sim.robot import RobotSpec, wheel_speeds

V1 = BoxPushingV1Config()
SPEC = RobotSpec()


def within(sample, mean, std):
    """Sample mean and standard deviation of ``sample`` agree with ``mean`` and ``std`` (5-sigma bounds)."""
    n = sample.size
    assert abs(sample.mean() - mean) < 5 * std / math.sqrt(n) + 1e-9
    assert abs(sample.std(ddof=1) - std) < 5 * std / math.sqrt(2 * n) + 1e-9


def robot_facing_a_wall(distance):
    """A robot whose front ray (sensor 2, 10° left of the heading) meets a wall ``distance`` from its rim."""
    world = World((1.0, 1.0))
    world.add(Wall("w", (0.5, 0.0), (0.5, 1.0), 0.002))
    x = 0.499 - SPEC.radius - distance * math.cos(math.radians(10))
    robot = world.add(DiffDriveRobot("r", (x, 0.5), 0.0))
    return world, robot


# -- proximity -----------------------------------------------------------------------------------


def test_proximity_relative_noise_scales_hit_distances_and_leaves_free_rays_free():
    world, robot = robot_facing_a_wall(0.04)
    exact = ProximityRing(max_range=0.1).read(robot, world.space)
    ring = ProximityRing(max_range=0.1, relative_noise=0.05)
    rng = np.random.default_rng(1)
    readings = np.array([ring.read(robot, world.space, rng) for _ in range(4000)])
    hit = exact < 0.1
    assert hit[2] and not hit[6]
    within(readings[:, 2].astype(float), exact[2], 0.05 * exact[2])
    assert np.all(readings[:, ~hit] == 0.1)  # nothing in range: the noise floor reads beyond range


def test_proximity_additive_noise_is_the_old_model():
    """``noise_std`` alone draws exactly as before: one normal per ray, then clipping."""
    world, robot = robot_facing_a_wall(0.04)
    exact = ProximityRing(max_range=0.1).read(robot, world.space)
    noisy = ProximityRing(max_range=0.1, noise_std=0.002).read(robot, world.space, np.random.default_rng(3))
    expected = np.clip(exact + np.random.default_rng(3).normal(0.0, 0.002, size=8), 0.0, 0.1)
    assert np.array_equal(noisy, expected.astype(np.float32))


# -- light ---------------------------------------------------------------------------------------


def test_light_relative_noise_and_per_robot_gains():
    world = World((2.0, 1.0))
    robots = [world.add(DiffDriveRobot(f"r{i}", (0.2 + 0.05 * i, 0.2 + 0.03 * i), 0.3 * i)) for i in range(8)]
    exact = LightSensor((1.5, 0.5))
    noisy = LightSensor((1.5, 0.5), relative_noise=0.1)
    rng = np.random.default_rng(2)
    truth = exact.read(robots[0], world.space)
    readings = np.array([noisy.read(robots[0], world.space, rng) for _ in range(3000)])
    lit = truth > 0.5
    for i in np.flatnonzero(lit):
        within(readings[:, i].astype(float), truth[i], 0.1 * truth[i])
    assert np.all(readings[:, ~lit] >= 0)
    # Gains: fixed per robot and sensor, log-normal; averaging readings does not remove them.
    calibrated = LightSensor((1.5, 0.5), gain_spread=0.2)
    logs = []
    for _ in range(250):
        for robot in robots:
            calibrated.calibrate(robot, rng)
            logs.append(np.log(calibrated.gains(robot)))
    within(np.concatenate(logs), 0.0, 0.2)
    gains = calibrated.gains(robots[1])
    reading = calibrated.read(robots[1], world.space, rng)
    assert np.allclose(reading, exact.read(robots[1], world.space) * gains, rtol=1e-6)
    calibrated.forget_calibrations()
    assert np.array_equal(calibrated.gains(robots[1]), np.ones(8))


def test_v1_light_does_not_reveal_the_lamp_distance():
    """Two robots at the same spot read intensities that differ by their sensors' gains (about 20 %)."""
    env = teamgym.make("BoxPushing-v1", n_robots=8, n_light_boxes=1)
    env.reset(seed=4)
    front = [env.light_gains(a)[2] for a in env.agents]
    assert 0.1 < np.std(np.log(front)) < 0.4


# -- encoders and motors -------------------------------------------------------------------------


def test_encoders_count_ticks_without_accumulating_error():
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.0))
    encoders = WheelEncoders(resolution=KHEPERA_ENCODER_RESOLUTION)
    out = np.zeros((1, 4))
    total = np.zeros(2)
    robot.set_wheel_speeds(0.033, 0.021)
    for _ in range(40):
        world.step()
        encoders.read_rows(world, [robot], world.robot_states, None, out)
        ticks = out[0, 2:] / KHEPERA_ENCODER_RESOLUTION
        assert np.allclose(ticks, np.round(ticks))
        assert np.allclose(out[0, :2], (robot.encoders.commanded_left, robot.encoders.commanded_right))
        total += out[0, 2:]
    exact = np.array([robot.encoders.total_left, robot.encoders.total_right])
    assert np.all(np.abs(total - exact) < KHEPERA_ENCODER_RESOLUTION)  # under one tick after 40 steps


def test_encoder_noise_is_relative_per_wheel():
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.0))
    robot.set_wheel_speeds(0.05, 0.05)
    world.step()
    world.step()
    encoders = WheelEncoders(noise_std=0.04)
    rng = np.random.default_rng(5)
    out = np.zeros((1, 4))
    ratios = []
    for _ in range(3000):
        encoders.read_rows(world, [robot], world.robot_states, rng, out)
        ratios.append(out[0, 2:] / (robot.encoders.actual_left, robot.encoders.actual_right))
    within(np.array(ratios).ravel(), 1.0, 0.04)


def test_motor_noise_scales_each_wheel_speed():
    env = teamgym.make("BoxPushing-v1", n_robots=1, n_light_boxes=1, action_type="wheels", max_cycles=200)
    env.reset(seed=6)
    robot = env.robots["robot_0"]
    ratios = []
    for _ in range(150):
        env.step({"robot_0": np.array([0.05, 0.05], dtype=np.float32)})
        ratios.append(np.array(wheel_speeds(*robot.command, SPEC.wheel_base)) / 0.05)
        if not env.agents:
            break
    within(np.array(ratios).ravel(), 1.0, V1.motor_noise)


def test_sensor_suite_rows_equal_one_robot_at_a_time_with_every_noise_on():
    world = World((1.0, 1.0))
    world.add_boundary()
    robots = [world.add(DiffDriveRobot(f"r{i}", (0.05 + 0.2 * i, 0.06 + 0.1 * i), 0.5 * i)) for i in range(4)]
    for robot in robots:
        robot.set_wheel_speeds(0.1, 0.07)
    world.step()
    ring = ProximityRing(max_range=0.1, noise_std=0.001, relative_noise=0.05)
    light = LightSensor((1.2, 0.5), noise_std=0.01, relative_noise=0.1, gain_spread=0.2)
    for robot in robots:
        light.calibrate(robot, np.random.default_rng(7))
    suite = SensorSuite({"p": ring, "l": light, "e": WheelEncoders(0.04, KHEPERA_ENCODER_RESOLUTION)})
    together = np.zeros((4, suite.width))
    suite.read_rows(world, robots, world.robot_states, np.random.default_rng(8), together)
    rng = np.random.default_rng(8)
    for i, robot in enumerate(robots):
        alone = np.zeros((1, suite.width))
        suite.read_rows(world, [robot], world.robot_states[i : i + 1], rng, alone)
        assert np.array_equal(alone[0], together[i])


# -- zero noise is the exact model ---------------------------------------------------------------


def rollout(env_id, seed=3, steps=120, **config):
    """Flat observations and rewards of a seeded episode with fixed primitive choices."""
    env = teamgym.make(env_id, situation="S2", max_cycles=steps, **config)
    obs, _ = env.reset(seed=seed)
    out = [np.concatenate([obs[a] for a in sorted(obs)])]
    choices = [int(Primitive.GO_AHEAD), int(Primitive.TURN_LEFT), int(Primitive.PUSH_STRAIGHT), int(Primitive.DIRECTION_CHANGE)]
    for t in range(steps):
        if not env.agents:
            break
        obs, rewards, *_ = env.step({a: choices[(t // 7 + i) % 4] for i, a in enumerate(env.agents)})
        out.append(np.concatenate([obs[a] for a in sorted(obs)] + [np.array(list(rewards.values()), dtype=np.float32)]))
    return np.concatenate(out)


def test_zero_noise_is_bit_identical_to_the_noiseless_model():
    noiseless = rollout("BoxPushing-v1", noise=0.0)
    zeros = {key: 0.0 for key in V1.NOISE_KEYS} | {"encoder_resolution": 0.0}
    assert np.array_equal(noiseless, rollout("BoxPushing-v1", **zeros))
    assert not np.array_equal(noiseless, rollout("BoxPushing-v1"))
    # v1 with v0's table and no noise is v0, bit for bit; v0's new keys at 0 change nothing.
    v0 = rollout("BoxPushing-v0")
    assert np.array_equal(v0, rollout("BoxPushing-v1", table_friction="joint", noise=0.0))
    assert np.array_equal(v0, rollout("BoxPushing-v0", noise=0.0, light_gain_spread=0.0, encoder_noise=0.0))


def test_noise_scale_multiplies_every_level():
    env = teamgym.make("BoxPushing-v1", noise=2.0)
    assert env.ring.relative_noise == pytest.approx(2 * V1.sensor_noise_relative)
    assert env.light.relative_noise == pytest.approx(2 * V1.light_noise_relative)
    assert env.light.gain_spread == pytest.approx(2 * V1.light_gain_spread)
    encoders = env.sensors.sensors["encoders"]
    assert encoders.noise_std == pytest.approx(2 * V1.encoder_noise) and encoders.resolution == V1.encoder_resolution
    assert teamgym.make("BoxPushing-v1", noise=0.0).sensors.sensors["encoders"].resolution == 0.0
    with pytest.raises(teamgym.ConfigError, match="noise"):
        teamgym.make("BoxPushing-v1", noise=-1.0)
    with pytest.raises(teamgym.ConfigError, match="encoder_resolution"):
        teamgym.make("BoxPushing-v1", encoder_resolution=-0.1)
