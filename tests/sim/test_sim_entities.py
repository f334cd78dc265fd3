"""Entities describe themselves: the world groups them and the renderer draws them without a list of types."""

import math

import numpy as np
import pymunk
import pytest

from teamgym.sim import (
    Box,
    Category,
    DiffDriveRobot,
    Door,
    Entity,
    Lamp,
    Layer,
    MovingPolygon,
    Renderer,
    StaticPolygon,
    Target,
    Wall,
    World,
    regular_polygon,
)
from teamgym.sim.categories import SOLID


class Puck(Entity):
    """A user-defined sliding disc: tracked, drawn as a purple disc, kicked every step by its hooks."""

    kind = Category.FURNITURE
    draw_layer = Layer.MOVING
    tracked = True
    has_state_row = True
    colour = (128, 0, 128)

    def __init__(self, name, position, radius=0.04):
        super().__init__(name)
        self.radius = radius
        self.body = pymunk.Body(0.1, pymunk.moment_for_circle(0.1, 0, radius))
        self.body.position = position
        self._own(pymunk.Circle(self.body, radius), mask=SOLID)
        self.bodies = [self.body]
        self.log = []

    def before_step(self, world, state):
        self.log.append(("before", world.time, tuple(state)))
        self.body.velocity = (0.2, 0.0)
        return None

    def after_step(self, world, start, end):
        self.log.append(("after", world.time, tuple(start), tuple(end)))

    def draw(self, canvas):
        canvas.disc(self.position, self.radius * canvas.scale, self.colour, (0, 0, 0))


class Flag(Entity):
    """A user-defined mark without a body, drawn above everything but robots."""

    kind = Category.TARGET
    draw_layer = Layer.LAMPS + 1

    def __init__(self, name, position):
        super().__init__(name)
        self.at = position

    @property
    def position(self):
        return self.at

    def draw(self, canvas):
        canvas.line([self.at, (self.at[0], self.at[1] + 0.1)], (0, 0, 0), 3)


def test_a_new_entity_type_is_stepped_tracked_and_drawn():
    world = World((1.0, 0.6))
    world.add_boundary()
    robot = world.add(DiffDriveRobot("r", (0.2, 0.15), 0.0))
    puck = world.add(Puck("puck", (0.3, 0.4)))
    world.add(Flag("flag", (0.8, 0.2)))
    assert world.tracked() == [robot, puck]
    assert world.robots == [robot] and world.movers == [] and world.boxes == []
    renderer = Renderer(world)
    for _ in range(3):
        robot.set_command(0.1, 0.0)
        world.step()
    assert [entry[0] for entry in puck.log] == ["before", "after"] * 3
    assert puck.log[-1][3][:2] == pytest.approx(tuple(puck.body.position))
    assert world.states.shape == (2, 6) and world.robot_states.shape == (1, 6)
    np.testing.assert_array_equal(world.states[1, :2], tuple(puck.body.position))
    assert puck.position[0] == pytest.approx(0.3 + 0.2 * 0.3, abs=1e-3)
    frame = renderer.draw()
    cx, cy = renderer.to_pixels(*puck.position)
    assert tuple(frame[int(cy), int(cx)]) == Puck.colour
    fx, fy = renderer.to_pixels(0.8, 0.25)
    assert tuple(frame[int(fy), int(fx)]) == (0, 0, 0)


def test_a_new_stateful_entity_leaves_robots_untouched():
    """A robot far from the puck moves exactly as in a world without it."""

    def run(with_puck):
        world = World((1.0, 1.0))
        robot = world.add(DiffDriveRobot("r", (0.2, 0.2), 0.3))
        if with_puck:
            world.add(Puck("puck", (0.8, 0.8)))
        for i in range(10):
            robot.set_command(0.2, 0.5 * math.sin(i))
            world.step()
        return world.robot_states.copy(), robot.encoders

    assert np.array_equal(run(True)[0], run(False)[0]) and run(True)[1] == run(False)[1]


def test_world_groups_by_kind_in_insertion_order():
    world = World((2.0, 2.0))
    square = regular_polygon(4, 0.05)
    order = [
        DiffDriveRobot("r0", (0.2, 0.2)),
        MovingPolygon("m0", square, (1.0, 1.0), (0.1, 0.0)),
        Box("b0", (0.05, 0.05), (1.5, 0.3), 0.1),
        DiffDriveRobot("r1", (0.2, 0.6)),
        Wall("w", (0.0, 1.9), (1.0, 1.9)),
        MovingPolygon("m1", square, (1.0, 1.5), (0.0, 0.1)),
        Box("b1", (0.05, 0.05), (1.5, 0.6), 0.1),
        DiffDriveRobot("r2", (0.2, 1.0)),
    ]
    robots = world.robots
    for entity in order:
        world.add(entity)
    assert [e.name for e in world.robots] == ["r0", "r1", "r2"] and world.robots is robots
    assert [e.name for e in world.movers] == ["m0", "m1"] and [e.name for e in world.boxes] == ["b0", "b1"]
    assert [e.name for e in world.tracked()] == ["r0", "m0", "b0", "r1", "m1", "b1", "r2"]
    world.step()
    # One batched read: robots first, then moving obstacles (ascending kind), each in insertion order.
    bodies = [e.body for e in world.robots + world.movers]
    expected = np.array([(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in bodies])
    np.testing.assert_array_equal(world.states, expected)
    np.testing.assert_array_equal(world.robot_states, expected[:3])
    np.testing.assert_array_equal(world.mover_states, expected[3:])
    world.remove("r1")
    world.remove("m0")
    world.add(DiffDriveRobot("r1", (0.5, 0.5)))
    assert [e.name for e in world.robots] == ["r0", "r2", "r1"] and [e.name for e in world.movers] == ["m1"]
    robot_states, mover_states = world.read_states()
    assert robot_states.shape == (3, 6) and mover_states.shape == (1, 6)
    np.testing.assert_array_equal(robot_states[2, :2], (0.5, 0.5))


def test_built_in_entities_declare_layer_and_tracking():
    square = regular_polygon(4, 0.05)
    cases = [
        (Wall("w", (0, 0), (1, 0)), Layer.STATIC, False),
        (Door("d", (0, 0), (1, 0)), Layer.STATIC, False),
        (StaticPolygon("s", square), Layer.STATIC, False),
        (MovingPolygon("m", square, (0.5, 0.5), (0, 0)), Layer.MOVING, True),
        (Box("b", (0.1, 0.1), (0.5, 0.5), 0.1), Layer.MOVING, True),
        (Target("t", (0.5, 0.5)), Layer.MARKS, False),
        (Lamp("l", (0.5, 0.5)), Layer.LAMPS, False),
        (DiffDriveRobot("r", (0.5, 0.5)), Layer.ROBOTS, True),
    ]
    for entity, layer, tracked in cases:
        assert (entity.draw_layer, entity.tracked) == (layer, tracked), entity
    assert list(Layer) == sorted(Layer)


def test_lamp_is_a_point_without_physics():
    world = World((1.0, 1.0))
    lamp = world.add(Lamp("lamp", (0.5, 0.5)))
    assert lamp.shapes == [] and lamp.bodies == [] and lamp.kind == Category.LAMP
    lamp.position = (0.2, 0.3)
    assert lamp.position == (0.2, 0.3) and world.of_kind(Category.LAMP) == [lamp]
    world.step()
    assert world.contacts == [] and world.tracked() == []
