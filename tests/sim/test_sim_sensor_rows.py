"""The Sensor protocol: ``read_rows`` of several robots equals the per-robot ``read``, noise included."""

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from teamgym.sim import (
    Box,
    Camera,
    Category,
    DiffDriveRobot,
    Lamp,
    LightSensor,
    MovingPolygon,
    ProximityRing,
    Sensor,
    SensorSuite,
    Target,
    Wall,
    WheelEncoders,
    World,
    regular_polygon,
)


@pytest.fixture
def crowd():
    """Five robots near walls, a box, an obstacle and each other, after a few steps of driving."""
    world = World((1.5, 1.0))
    world.add_boundary()
    world.add(Wall("screen", (0.9, 0.3), (0.9, 0.7), 0.01))
    world.add(Box("box", (0.06, 0.06), (0.5, 0.55), 0.05))
    world.add(MovingPolygon("obstacle", regular_polygon(5, 0.05), (1.2, 0.5), (0.0, 0.1)))
    world.add(Target("goal", (0.6, 0.3)))
    spots = [(0.05, 0.05, 0.3), (0.45, 0.5, 0.8), (0.55, 0.45, 2.0), (0.85, 0.5, -0.2), (1.4, 0.9, 3.0)]
    robots = [world.add(DiffDriveRobot(f"r{i}", (x, y), a)) for i, (x, y, a) in enumerate(spots)]
    for step in range(3):
        for i, robot in enumerate(robots):
            robot.set_command(0.1 + 0.05 * i, (-1) ** i * 0.8 * step)
        world.step()
    return world, robots


def poses_of(world):
    return world.robot_states[:, :3]


def per_robot(read, world, robots, width, seed):
    rng = np.random.default_rng(seed)
    out = np.zeros((len(robots), width), dtype=np.float32)
    for i, robot in enumerate(robots):
        read(robot, world.space, rng, out=out[i], pose=tuple(poses_of(world)[i].tolist()))
    return out, rng


def by_rows(sensor, world, robots, seed, dtype=np.float32):
    rng = np.random.default_rng(seed)
    out = np.full((len(robots), sensor.width), np.nan, dtype=dtype)
    sensor.read_rows(world, robots, world.robot_states, rng, out)
    return out, rng


def test_every_sensor_follows_the_protocol():
    for sensor in (ProximityRing(), LightSensor((0, 0)), Camera(), WheelEncoders(), SensorSuite({"e": WheelEncoders()})):
        assert isinstance(sensor, Sensor)
    assert ProximityRing().width == 8 and LightSensor((0, 0)).width == 8 and WheelEncoders().width == 4
    assert Camera(kinds=(Category.BOX, Category.ROBOT), slots=2).width == 12


@pytest.mark.parametrize("max_range", [0.1, 0.3])
def test_ring_reads_of_many_worlds_at_once_equal_each_worlds_rows(crowd, max_range):
    """``read_many`` over robots of two worlds (the same scene, one moved on) gives each world's ``read_values``."""
    world, robots = crowd
    other = World((1.5, 1.0))
    other.add_boundary()
    moved = [other.add(DiffDriveRobot(f"q{i}", (0.1 + 0.3 * i, 0.08 + 0.2 * i), 0.7 * i)) for i in range(4)]
    other.read_states()
    ring = ProximityRing(max_range=max_range)
    expected = []
    for w, rs in ((world, robots), (other, moved)):
        rows = np.zeros((len(rs), ring.width), dtype=np.float32)
        ring.read_values(w, rs, w.robot_states, rows, None)
        expected.append(rows)
    out = np.full((len(robots) + len(moved), ring.width), np.nan, dtype=np.float32)
    poses = np.concatenate([world.robot_states, other.robot_states])
    ring.read_many([world.space] * len(robots) + [other.space] * len(moved), [*robots, *moved], poses, out)
    np.testing.assert_array_equal(out, np.concatenate(expected))
    assert np.any(out < max_range) and np.any(out == np.float32(max_range))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ring_rows_equal_reads_one_robot_after_the_other(crowd, seed):
    world, robots = crowd
    ring = ProximityRing(max_range=0.1, noise_std=0.01)
    expected, rng_a = per_robot(ring.read, world, robots, ring.width, seed)
    actual, rng_b = by_rows(ring, world, robots, seed)
    np.testing.assert_array_equal(actual, expected)
    assert rng_a.random() == rng_b.random()  # the same number of draws
    assert np.any(actual < 0.09) and np.any(actual == np.float32(0.1))


@pytest.mark.parametrize("lamp", ["point", "entity"])
def test_light_rows_equal_reads_one_robot_after_the_other(crowd, lamp):
    world, robots = crowd
    source = (1.45, 0.15) if lamp == "point" else world.add(Lamp("lamp", (1.45, 0.15)))
    light = LightSensor(source, noise_std=0.05)
    expected, rng_a = per_robot(light.read, world, robots, light.width, 4)
    actual, rng_b = by_rows(light, world, robots, 4)
    np.testing.assert_array_equal(actual, expected)
    assert rng_a.random() == rng_b.random()
    noiseless = by_rows(LightSensor(source), world, robots, 4)[0]
    assert np.all(noiseless[3] == 0) and noiseless[0].max() > 0  # r3 is behind the screen, r0 is not


@pytest.mark.parametrize("saturation", [None, 30.0])
def test_unshadowed_light_rows_in_one_pass_equal_reads_one_robot_after_the_other(crowd, saturation):
    world, robots = crowd
    light = LightSensor((0.1, 0.1), blockers=0, noise_std=0.05, relative_noise=0.1, gain_spread=0.2, saturation=saturation)
    for robot in robots:
        light.calibrate(robot, np.random.default_rng(len(robot.name)))
    expected, rng_a = per_robot(light.read, world, robots, light.width, 4)
    actual, rng_b = by_rows(light, world, robots, 4)
    np.testing.assert_array_equal(actual, expected)
    assert rng_a.random() == rng_b.random()
    if saturation is not None:
        assert actual.max() == saturation  # r0 sits near the lamp: its sensor saturates
    noiseless = LightSensor((0.1, 0.1), blockers=0, saturation=saturation)
    single = np.stack([noiseless.read(r, world.space, pose=tuple(p)) for r, p in zip(robots, poses_of(world).tolist())])
    np.testing.assert_array_equal(by_rows(noiseless, world, robots, 0)[0], single)


@given(
    poses=st.lists(
        st.tuples(*(st.floats(-2.0, 3.0, allow_nan=False),) * 2, st.floats(-20.0, 20.0, allow_nan=False)), min_size=1, max_size=40
    ),
    saturation=st.sampled_from([None, 5.0, 400.0]),
    at_lamp=st.booleans(),
)
@settings(max_examples=60, deadline=None)
def test_light_of_a_pose_array_equals_the_rows_of_its_lists(poses, saturation, at_lamp):
    """``shine_array`` (element-wise ``math``) gives :meth:`LightSensor.shine_rows`'s bits, at the lamp too."""
    light = LightSensor((0.4, 0.7), blockers=0, saturation=saturation)
    array = np.array(poses, dtype=float)
    if at_lamp:
        array[0, :2] = light.lamp  # within min_distance: the distance is clamped
    expected, actual = (np.empty((len(array), light.width), dtype=np.float32) for _ in range(2))
    light.shine_rows(array.tolist(), expected)
    light.shine_array(array, actual)
    assert np.array_equal(expected.view(np.uint32), actual.view(np.uint32))


def test_light_follows_a_moving_lamp():
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (0.5, 1.0), 0.0))
    lamp = world.add(Lamp("lamp", (1.5, 1.0)))
    sensor = LightSensor(lamp)
    ahead = sensor.read(robot, world.space).copy()
    lamp.position = (0.5, 2.0)  # now to the robot's left
    np.testing.assert_array_equal(sensor.read(robot, world.space), LightSensor((0.5, 2.0)).read(robot, world.space))
    assert sensor.lamp == (0.5, 2.0) and int(np.argmax(ahead)) in (2, 3)


def test_camera_rows_hold_the_nearest_sightings_per_kind(crowd):
    world, robots = crowd
    camera = Camera(fov=math.radians(120), max_range=0.6, kinds=(Category.ROBOT, Category.BOX, Category.TARGET), slots=2)
    rows, _ = by_rows(camera, world, robots, 0, dtype=np.float64)
    for robot, pose, row in zip(robots, world.robot_states[:, :3], rows):
        seen = camera.read(robot, world.entities.values(), world.space, pose=tuple(pose.tolist()))
        expected = np.zeros(camera.width)
        for k, kind in enumerate(camera.kind_order):
            nearest = sorted((s for s in seen if s.kind == kind), key=lambda s: s.distance)[:2]
            for slot, s in enumerate(nearest):
                expected[6 * k + 3 * slot : 6 * k + 3 * slot + 3] = (1.0, s.distance, s.bearing)
        np.testing.assert_array_equal(row, expected)
    assert rows[:, 0].sum() >= 1 and rows[:, 6].sum() >= 2 and rows[:, 12].sum() >= 1  # robots, boxes, goal seen


def test_wheel_encoders_rows(crowd):
    world, robots = crowd
    rows, _ = by_rows(WheelEncoders(), world, robots, 0)
    for robot, row in zip(robots, rows):
        e = robot.encoders
        assert row.tolist() == np.float32([e.commanded_left, e.commanded_right, e.actual_left, e.actual_right]).tolist()


def test_wheel_encoders_free_driving_and_stalled():
    world = World((1.0, 1.0))
    world.add_boundary()
    free = world.add(DiffDriveRobot("free", (0.3, 0.5), 0.0))
    stuck = world.add(DiffDriveRobot("stuck", (1.0 - 0.0275, 0.2), 0.0))  # touching the east wall
    for _ in range(3):
        free.set_command(0.2, 0.0)
        stuck.set_command(0.2, 0.0)
        world.step()
    out = np.zeros((2, 4))
    WheelEncoders().read_rows(world, [free, stuck], world.robot_states, None, out)
    turn = 0.2 * 0.1 / free.spec.wheel_radius  # v Δt / r = 2.5 rad per step
    np.testing.assert_allclose(out[0], [turn, turn, turn, turn], rtol=1e-3)
    np.testing.assert_allclose(out[1, :2], [turn, turn], rtol=1e-12)
    assert np.all(np.abs(out[1, 2:]) < 0.05 * turn)  # the wall holds it: no actual rotation


@pytest.mark.parametrize("seed", [0, 7])
def test_suite_reads_robot_after_robot_like_an_env_loop(crowd, seed):
    """The draws interleave as in an env that reads the ring, then the light, of each robot in turn."""
    world, robots = crowd
    ring, light = ProximityRing(noise_std=0.01), LightSensor((1.45, 0.15), noise_std=0.05)
    suite = SensorSuite({"proximity": ring, "light": light, "encoders": WheelEncoders()})
    rng = np.random.default_rng(seed)
    expected = np.zeros((len(robots), 20), dtype=np.float32)
    for i, robot in enumerate(robots):
        pose = tuple(world.robot_states[i, :3].tolist())
        ring.read(robot, world.space, rng, out=expected[i, 0:8], pose=pose)
        light.read(robot, world.space, rng, out=expected[i, 8:16], pose=pose)
        e = robot.encoders
        expected[i, 16:] = (e.commanded_left, e.commanded_right, e.actual_left, e.actual_right)
    actual, _ = by_rows(suite, world, robots, seed)
    np.testing.assert_array_equal(actual, expected)
    assert suite.width == 20 and suite.slices["light"] == slice(8, 16)


def test_rows_of_a_subset_of_robots(crowd):
    world, robots = crowd
    ring = ProximityRing(noise_std=0.01)
    rows = [3, 0]
    out = np.zeros((2, 8), dtype=np.float32)
    ring.read_rows(world, [robots[i] for i in rows], world.robot_states[rows], np.random.default_rng(1), out)
    rng = np.random.default_rng(1)
    one_by_one = [ring.read(robots[i], world.space, rng, pose=tuple(world.robot_states[i, :3].tolist())) for i in rows]
    np.testing.assert_array_equal(out, np.array(one_by_one))


def test_read_rows_checks_shapes(crowd):
    world, robots = crowd
    with pytest.raises(ValueError, match="out must have shape"):
        ProximityRing().read_rows(world, robots, world.robot_states, None, np.zeros((len(robots), 7)))
    with pytest.raises(ValueError, match="poses"):
        LightSensor((0, 0)).read_rows(world, robots, world.robot_states[:2], None, np.zeros((len(robots), 8)))
    with pytest.raises(ValueError, match="out must have shape"):
        WheelEncoders().read_rows(world, robots, world.robot_states, None, np.zeros((1, 4)))


_wheel_value = st.floats(min_value=-40.0, max_value=40.0, allow_nan=False)
_encoder_raw = st.tuples(*[_wheel_value] * 4, *[st.floats(min_value=-1e4, max_value=1e4)] * 2)


@settings(max_examples=200, deadline=None, database=None)
@example(raw=[(0.0, 0.0, 0.0, -0.0, 0.0, -0.0)], noise_std=0.0, resolution=0.01, saturation=None, seed=0)  # zero's sign
@given(
    raw=st.lists(_encoder_raw, max_size=7),
    noise_std=st.sampled_from([0.0, 0.05]),
    resolution=st.sampled_from([0.0, 0.01, 2 * math.pi / 500]),
    saturation=st.sampled_from([None, 0.5, 30.0]),
    seed=st.integers(0, 3),
)
def test_wheel_encoders_in_one_pass_equal_the_robot_by_robot_formula(raw, noise_std, resolution, saturation, seed):
    """``WheelEncoders.read_raw`` (a batch's robots in one pass) gives ``read_drawn``'s bits; ``wheel_slips`` too."""
    from teamgym.sim.robot import wheel_slip, wheel_slips

    class Robot:  # what read_drawn reads of a robot
        def __init__(self, row):
            self.encoder_row = row

    encoders = WheelEncoders(noise_std=noise_std, resolution=resolution, saturation=saturation)
    z = np.random.default_rng(seed).standard_normal((len(raw), 2)) if noise_std else None
    rows = np.array(raw, dtype=float).reshape(len(raw), 6)
    out = np.full((len(raw), 4), np.nan, dtype=np.float32)
    encoders.read_raw(rows, z, out)
    robot_by_robot = np.full((len(raw), 4), np.nan, dtype=np.float32)
    encoders.read_drawn(None, [Robot(row) for row in raw], np.zeros((len(raw), 6)), z, robot_by_robot)
    assert out.tobytes() == robot_by_robot.tobytes()
    assert wheel_slips(rows).tolist() == [wheel_slip(*row[:4]) for row in raw]
