"""Passive objects: doors that open and close, walls, boxes and the world's bookkeeping."""

import math

import pymunk
import pytest

from teamgym.sim import Box, Category, DiffDriveRobot, Door, MovingPolygon, StaticPolygon, Target, Wall, World
from teamgym.sim.objects import GRAVITY

R = 0.0275
DOOR_T = 0.02


def doorway_world(door_open):
    """A wall across the arena at x = 1 with a 20 cm doorway between y = 0.9 and 1.1."""
    world = World((2.0, 2.0))
    world.add_boundary()
    world.add(Wall("lower", (1.0, 0.0), (1.0, 0.9), DOOR_T))
    world.add(Wall("upper", (1.0, 1.1), (1.0, 2.0), DOOR_T))
    door = world.add(Door("door", (1.0, 0.9), (1.0, 1.1), DOOR_T, is_open=door_open))
    return world, door


def drive(world, robot, v, seconds):
    for _ in range(round(seconds / world.dt)):
        robot.set_command(v, 0.0)
        world.step()


def test_closed_door_blocks_open_door_lets_through():
    world, door = doorway_world(door_open=False)
    assert not door.is_open
    robot = world.add(DiffDriveRobot("r", (0.7, 1.0), 0.0))
    drive(world, robot, 0.3, 2.0)
    x, y, _ = robot.pose
    assert 0.9 < x < 1.0 - DOOR_T / 2 - R + 2e-3  # stopped at the door
    assert y == pytest.approx(1.0, abs=1e-3)
    door.open()
    assert door.is_open
    drive(world, robot, 0.3, 2.0)
    assert robot.pose[0] > 1.3  # went through


def test_open_door_closes_and_then_blocks():
    world, door = doorway_world(door_open=True)
    robot = world.add(DiffDriveRobot("r", (0.7, 1.0), 0.0))
    drive(world, robot, 0.3, 2.0)
    assert robot.pose[0] > 1.2
    assert door.close() is True  # nobody in the doorway; the adjacent walls do not count
    assert not door.is_open
    robot.teleport(robot.pose[:2], math.pi)  # turn round and drive back
    drive(world, robot, 0.3, 3.0)
    assert 1.0 + DOOR_T / 2 + R - 2e-3 < robot.pose[0] < 1.1


def test_close_refuses_with_robot_in_doorway():
    world, door = doorway_world(door_open=True)
    robot = world.add(DiffDriveRobot("r", (0.99, 1.0), 0.0))
    assert door.close() is False
    assert door.is_open
    drive(world, robot, 0.3, 1.0)
    assert robot.pose[0] > 1.2  # the refused door did not trap it
    assert door.close() is True
    assert not door.is_open


def test_close_refuses_with_robot_partly_in_doorway():
    world, door = doorway_world(door_open=True)
    world.add(DiffDriveRobot("r", (1.0 - DOOR_T / 2 - R + 0.002, 1.05), 0.0))  # rim overlaps the door by 2 mm
    assert door.close() is False
    assert door.is_open


def test_close_refuses_with_box_in_doorway_and_allows_nearby_robot():
    world, door = doorway_world(door_open=True)
    box = world.add(Box("box", (0.05, 0.05), (1.0, 1.0), 0.05))
    assert door.close() is False
    world.remove("box")
    world.add(DiffDriveRobot("near", (1.0 - DOOR_T / 2 - R - 0.01, 1.0), 0.0))  # 1 cm short of the door
    assert door.close() is True
    assert box.space is None


def test_door_open_close_is_idempotent():
    world, door = doorway_world(door_open=False)
    assert door.close() is True and not door.is_open
    door.open()
    door.open()
    assert door.is_open
    assert world.space.point_query_nearest((1.0, 1.0), 0.001, pymunk.ShapeFilter()) is None
    assert door.close() is True
    assert world.space.point_query_nearest((1.0, 1.0), 0.001, pymunk.ShapeFilter()) is not None


def test_box_friction_force():
    box = Box("b", (0.1, 0.1), (0.0, 0.0), 0.2, ground_friction=0.5)
    assert box.friction_force == pytest.approx(0.5 * 0.2 * GRAVITY)
    assert box.pivot.max_force == pytest.approx(box.friction_force)
    assert box.kind == Category.BOX


@pytest.mark.parametrize(
    "factory",
    [
        lambda: Box("b", (0.0, 0.1), (0.0, 0.0), 0.1),
        lambda: Box("b", (0.1, 0.1), (0.0, 0.0), -0.1),
        lambda: Box("b", (0.1, 0.1), (0.0, 0.0), 0.1, ground_friction=-0.1),
        lambda: Wall("w", (0.0, 0.0), (1.0, math.nan)),
        lambda: Wall("w", (0.0, 0.0), (1.0, 0.0), thickness=0.0),
        lambda: StaticPolygon("p", [(0.0, 0.0), (1.0, 0.0)]),
        lambda: MovingPolygon("m", [(0, 0), (1, 0), (0, 1)], (0.0, 0.0), (0.0, 0.0), mass=math.inf),
        lambda: Target("", (0.0, 0.0)),
    ],
)
def test_objects_reject_bad_parameters(factory):
    with pytest.raises(ValueError):
        factory()


def test_world_names_are_unique_and_removable():
    world = World((1.0, 1.0))
    world.add(DiffDriveRobot("a", (0.5, 0.5)))
    with pytest.raises(ValueError, match="'a'"):
        world.add(DiffDriveRobot("a", (0.2, 0.2)))
    with pytest.raises(KeyError, match="'zz'"):
        world["zz"]
    robot = world.remove("a")
    assert robot.space is None and world.robots == [] and "a" not in world.entities
    with pytest.raises(KeyError, match="'a'"):
        world.remove("a")
    with pytest.raises(ValueError):
        World((1.0, 1.0), dt=0.0)


def test_world_records_contacts_between_entities():
    world = World((1.0, 1.0))
    world.add_boundary()
    robot = world.add(DiffDriveRobot("r", (0.9, 0.5), 0.0))
    seen = []
    for _ in range(10):
        robot.set_command(0.3, 0.0)
        world.step()
        seen.extend(world.contacts)
    assert any({c.a, c.b} == {"r", "wall_east"} for c in seen)
    assert all(Category.ROBOT in (c.kind_a, c.kind_b) for c in seen)
    # Contacts are those that began in the last step only.
    robot.set_command(0.3, 0.0)
    world.step()
    assert world.contacts_of("r") == []


def test_world_pickle_just_after_impact_continues_identically():
    """pymunk's pickle leaves out each body's bias velocity (the pending overlap correction);
    ``SolverSpace`` adds it, so a world pickled just after an impact continues bit for bit."""
    import pickle

    world = World((1.0, 1.0))
    world.add_boundary()
    robot = world.add(DiffDriveRobot("r", (0.9, 0.5), 0.0))
    for _ in range(3):  # the robot hits the east wall during the third step
        robot.set_command(0.4, 0.0)
        world.step()
    assert world.contacts_of("r")
    clone = pickle.loads(pickle.dumps(world))
    twin = clone["r"]
    for _ in range(5):
        robot.set_command(0.4, 0.0)
        twin.set_command(0.4, 0.0)
        world.step()
        clone.step()
        assert tuple(twin.body.position) == tuple(robot.body.position)


@pytest.mark.parametrize("solid_to_each_other", [True, False])
def test_moving_polygons_collide_unless_masked(solid_to_each_other):
    from teamgym.sim.categories import SOLID
    from teamgym.sim.objects import regular_polygon

    mask = SOLID if solid_to_each_other else SOLID & ~Category.OBSTACLE.bit
    world = World((4.0, 4.0), dt=0.1)
    square = regular_polygon(4, 0.1)
    a = world.add(MovingPolygon("a", square, (1.0, 2.0), (0.2, 0.0), bounce=False, collides_with=mask))
    b = world.add(MovingPolygon("b", square, (3.0, 2.0), (-0.2, 0.0), bounce=False, collides_with=mask))
    for _ in range(80):  # 8 s: they would meet in the middle after about 4.5 s
        world.step()
    if solid_to_each_other:
        assert abs(a.position[1] - 2.0) > 0.02 and abs(b.position[1] - 2.0) > 0.02  # pushed off their lines
    else:
        assert a.position[0] == pytest.approx(2.6, abs=1e-3) and b.position[0] == pytest.approx(1.4, abs=1e-3)
        assert a.target_velocity == (0.2, 0.0)  # bounce=False: never reflected, even leaving nothing
