"""Proximity ring (numbering of paper 004 Fig. 3), light sensor and camera."""

import math

import numpy as np
import pymunk
import pytest

from teamgym.sim import (
    KHEPERA_RING,
    Box,
    Camera,
    Category,
    DiffDriveRobot,
    LightSensor,
    MovingPolygon,
    ProximityRing,
    StaticPolygon,
    Target,
    Wall,
    World,
    regular_polygon,
)
from teamgym.sim.categories import RAY_HITS

R = 0.0275  # default robot radius
WALL_T = 0.01


def wall_facing(world, robot, direction, gap, name="w"):
    """A long wall whose near face is ``gap`` from the robot's rim in body-frame ``direction``."""
    x, y, theta = robot.pose
    phi = theta + direction
    n = np.array([math.cos(phi), math.sin(phi)])
    t = np.array([-n[1], n[0]])
    centre = np.array([x, y]) + n * (R + gap + WALL_T / 2)
    a, b = centre - 0.5 * t, centre + 0.5 * t
    return world.add(Wall(name, tuple(a), tuple(b), WALL_T))


def expected_ring(direction, gap, max_range):
    """Exact readings of the ring for an infinite wall at body-frame ``direction``."""
    out = []
    for alpha in KHEPERA_RING:
        c = math.cos(alpha - direction)
        d = (R + gap - R * c) / c if c > 1e-9 else math.inf
        out.append(min(d, max_range))
    return np.array(out)


def test_ring_numbering_matches_paper():
    deg = np.rad2deg(KHEPERA_RING)
    assert deg[0] == pytest.approx(90)  # 0: left
    assert all(-90 < a < 90 for a in deg[1:5])  # 1-4: front, left to right
    assert list(deg[1:5]) == sorted(deg[1:5], reverse=True)
    assert deg[5] == pytest.approx(-90)  # 5: right
    assert all(abs(a) > 90 for a in deg[6:8])  # 6-7: back


@pytest.mark.parametrize("theta", [0.0, 1.0, -2.5, math.pi / 2])
@pytest.mark.parametrize("gap", [0.005, 0.03, 0.07, 0.095])
def test_wall_to_the_left_is_seen_by_ray_0(theta, gap):
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), theta))
    wall_facing(world, robot, math.pi / 2, gap)
    ring = ProximityRing(max_range=0.1)
    reading = ring.read(robot, world.space)
    assert reading.dtype == np.float32 and reading.shape == (8,)
    assert reading[0] == pytest.approx(gap, abs=1e-3)
    assert int(np.argmin(reading)) == 0
    np.testing.assert_allclose(reading, expected_ring(math.pi / 2, gap, 0.1), atol=1e-3)
    assert np.all(reading[3:7] == np.float32(0.1))  # front-right, right and back see nothing


@pytest.mark.parametrize(
    ("direction", "nearest"),
    [(math.pi / 2, {0}), (-math.pi / 2, {5}), (0.0, {2, 3}), (math.pi, {6, 7})],
    ids=["left", "right", "front", "back"],
)
def test_ring_sees_wall_on_the_right_rays(direction, nearest):
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.4))
    wall_facing(world, robot, direction, 0.04)
    reading = ProximityRing(max_range=0.1).read(robot, world.space)
    closest = set(np.flatnonzero(reading <= reading.min() + 1e-4).tolist())
    assert closest == nearest
    np.testing.assert_allclose(reading, expected_ring(direction, 0.04, 0.1), atol=1e-3)


def test_nothing_in_range_reads_max_range():
    world = World((2.0, 2.0))
    world.add_boundary()
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.3))
    world.add(Wall("far", (1.0 + R + 0.101, 0.0), (1.0 + R + 0.101, 2.0), 0.001))
    ring = ProximityRing(max_range=0.1)
    assert np.array_equal(ring.read(robot, world.space), np.full(8, 0.1, dtype=np.float32))
    # The robot never sees itself, and the out array is filled in place.
    out = np.zeros(8, dtype=np.float32)
    assert ring.read(robot, world.space, out=out) is out
    assert np.all(out == np.float32(0.1))


def brute_force_ring(robot, space, angles, max_range):
    x, y = robot.body.position
    theta = robot.body.angle
    shape_filter = pymunk.ShapeFilter(group=robot.group, mask=RAY_HITS)
    out = np.full(len(angles), max_range)
    for i, alpha in enumerate(angles):
        d = (math.cos(theta + alpha), math.sin(theta + alpha))
        start = (x + robot.spec.radius * d[0], y + robot.spec.radius * d[1])
        end = (start[0] + max_range * d[0], start[1] + max_range * d[1])
        hit = space.segment_query_first(start, end, 0.0, shape_filter)
        if hit is not None:
            out[i] = hit.alpha * max_range
    return out


def test_ring_skip_gives_same_readings_as_casting_every_ray():
    rng = np.random.default_rng(7)
    world = World((2.0, 2.0))
    world.add_boundary()
    world.add(Wall("inner", (0.5, 0.5), (1.5, 0.6), 0.01))
    world.add(Box("box", (0.1, 0.06), (0.6, 1.4), 0.1, angle=0.3))
    world.add(StaticPolygon("table", [(1.3, 1.3), (1.5, 1.3), (1.5, 1.45)]))
    world.add(MovingPolygon("obstacle", regular_polygon(5, 0.06), (1.0, 1.0), (0.0, 0.0)))
    other = world.add(DiffDriveRobot("other", (1.2, 0.9), 0.0))
    robot = world.add(DiffDriveRobot("r", (0.3, 0.3), 0.0))
    ring = ProximityRing(max_range=0.1)
    seen_something = seen_nothing = 0
    for _ in range(600):
        position = tuple(rng.uniform(0.03, 1.97, size=2))
        robot.teleport(position, float(rng.uniform(-math.pi, math.pi)))
        if world.space.point_query_nearest(position, R + 1e-4, pymunk.ShapeFilter(group=robot.group)) is not None:
            continue  # overlapping placements are not meaningful
        fast = ring.read(robot, world.space)
        slow = brute_force_ring(robot, world.space, KHEPERA_RING, 0.1)
        np.testing.assert_allclose(fast, slow, atol=1e-6, err_msg=f"robot at {position}")
        if np.all(slow == 0.1):
            seen_nothing += 1
        else:
            seen_something += 1
    assert seen_something > 50 and seen_nothing > 50
    assert other.space is world.space


def test_ring_noise_is_seeded_and_clipped():
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.0))
    wall_facing(world, robot, 0.0, 0.002)
    ring = ProximityRing(max_range=0.1, noise_std=0.01)
    a = ring.read(robot, world.space, np.random.default_rng(3))
    b = ring.read(robot, world.space, np.random.default_rng(3))
    c = ring.read(robot, world.space, np.random.default_rng(4))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.all((a >= 0) & (a <= 0.1))


# -- light sensor ----------------------------------------------------------------------


def light_world(theta=0.0):
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (0.5, 1.0), theta))
    return world, robot, LightSensor(lamp=(1.5, 1.0), intensity=1.0)


def test_light_facing_lamp_is_brightest_in_front():
    world, robot, sensor = light_world(theta=0.0)
    reading = sensor.read(robot, world.space)
    assert set(np.flatnonzero(reading >= reading.max() - 1e-6).tolist()) == {2, 3}
    assert reading[2] == pytest.approx(math.cos(math.radians(10)) / 1.0**2, rel=1e-5)
    assert np.all(reading[[6, 7]] == 0)  # back sensors face away
    assert reading[0] == pytest.approx(0.0, abs=1e-6) and reading[5] == pytest.approx(0.0, abs=1e-6)


def test_light_lamp_to_the_left_is_brightest_on_sensor_0():
    world, robot, sensor = light_world(theta=-math.pi / 2)
    reading = sensor.read(robot, world.space)
    assert int(np.argmax(reading)) == 0
    assert reading[5] == 0


def test_light_falls_off_with_distance_squared():
    world, robot, sensor = light_world()
    near = sensor.read(robot, world.space).max()
    robot.teleport((1.0, 1.0), 0.0)
    far = sensor.read(robot, world.space).max()
    assert far == pytest.approx(near * 4, rel=1e-5)  # half the distance, four times the light


def test_opaque_wall_blocks_light():
    world, robot, sensor = light_world()
    world.add(Wall("screen", (1.0, 0.8), (1.0, 1.2), 0.01))
    assert np.all(sensor.read(robot, world.space) == 0)


def test_robot_between_blocks_light():
    world, robot, sensor = light_world()
    world.add(DiffDriveRobot("shade", (1.0, 1.0), 0.0))
    assert np.all(sensor.read(robot, world.space) == 0)


def test_box_between_does_not_block_light():
    world, robot, sensor = light_world()
    clear = sensor.read(robot, world.space).copy()
    world.add(Box("box", (0.1, 0.3), (1.0, 1.0), 0.1))
    with_box = sensor.read(robot, world.space)
    assert clear.max() > 0
    np.testing.assert_array_equal(with_box, clear)


# -- camera ------------------------------------------------------------------------------


def place(robot, distance, bearing):
    x, y, theta = robot.pose
    return (x + distance * math.cos(theta + bearing), y + distance * math.sin(theta + bearing))


@pytest.fixture
def camera_scene():
    world = World((3.0, 3.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.5))
    return world, robot, Camera(fov=math.radians(60), max_range=0.5)


def test_camera_reports_object_in_view(camera_scene):
    world, robot, camera = camera_scene
    world.add(Box("box", (0.05, 0.05), place(robot, 0.3, 0.2), 0.1))
    world.add(Target("goal", place(robot, 0.4, -0.4)))
    seen = {s.name: s for s in camera.read(robot, world.entities.values(), world.space)}
    assert set(seen) == {"box", "goal"}
    box = seen["box"]
    assert box.kind == Category.BOX
    assert box.distance == pytest.approx(0.3, abs=1e-9)
    assert box.bearing == pytest.approx(0.2, abs=1e-9)
    assert (box.x, box.y) == pytest.approx((0.3 * math.cos(0.2), 0.3 * math.sin(0.2)))
    assert seen["goal"].kind == Category.TARGET
    assert seen["goal"].bearing == pytest.approx(-0.4, abs=1e-9)


def test_camera_ignores_out_of_view_and_out_of_range(camera_scene):
    world, robot, camera = camera_scene
    world.add(Box("wide", (0.05, 0.05), place(robot, 0.3, 0.6), 0.1))  # 34 deg > 30 deg
    world.add(Box("behind", (0.05, 0.05), place(robot, 0.3, math.pi), 0.1))
    world.add(Box("far", (0.05, 0.05), place(robot, 0.55, 0.0), 0.1))
    world.add(Box("edge", (0.05, 0.05), place(robot, 0.45, -0.5), 0.1))  # just inside the FOV
    world.add(Wall("wall", place(robot, 0.2, 0.3), place(robot, 0.2, 0.1), 0.01))  # not a camera kind
    names = {s.name for s in camera.read(robot, world.entities.values(), world.space)}
    assert names == {"edge"}


def test_camera_occlusion(camera_scene):
    world, robot, camera = camera_scene
    world.add(MovingPolygon("hidden", regular_polygon(4, 0.03), place(robot, 0.4, 0.0), (0.0, 0.0)))
    world.add(Wall("screen", place(robot, 0.2, 0.2), place(robot, 0.2, -0.2), 0.01))
    world.add(Box("shielded", (0.04, 0.04), place(robot, 0.45, 0.25), 0.1))
    world.add(DiffDriveRobot("mate", place(robot, 0.2, 0.25), 0.0))
    world.add(Box("clear", (0.05, 0.05), place(robot, 0.15, -0.35), 0.1))
    world.add(Target("behind_box", place(robot, 0.3, -0.35)))
    names = {s.name for s in camera.read(robot, world.entities.values(), world.space)}
    # Wall and robot are opaque; a (clear plastic) box does not hide what lies behind it.
    assert names == {"mate", "clear", "behind_box"}
    blind = Camera(fov=math.radians(60), max_range=0.5, occlusion=False)
    all_names = {s.name for s in blind.read(robot, world.entities.values(), world.space)}
    assert all_names == {"hidden", "shielded", "mate", "clear", "behind_box"}


def test_camera_rejects_bad_parameters():
    with pytest.raises(ValueError, match="fov"):
        Camera(fov=0.0)
    with pytest.raises(ValueError, match="max_range"):
        Camera(max_range=-1.0)
    with pytest.raises(ValueError, match="max_range"):
        ProximityRing(max_range=0.0)
