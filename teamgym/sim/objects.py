"""Passive objects: walls, doors, static and moving convex polygons, boxes, targets, lamps."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pymunk

from teamgym.sim.canvas import Canvas, Layer
from teamgym.sim.categories import SOLID, Category
from teamgym.sim.entity import Entity, PointEntity

if TYPE_CHECKING:
    from teamgym.sim.world import World

GRAVITY = 9.81

Point = tuple[float, float]


def _check_points(name: str, points: Sequence[Point], minimum: int) -> list[Point]:
    pts = [(float(x), float(y)) for x, y in points]
    if len(pts) < minimum or not all(math.isfinite(c) for p in pts for c in p):
        raise ValueError(f"{name}: need at least {minimum} finite points, got {points!r}")
    return pts


class Wall(Entity):
    """A straight wall segment of a given thickness (static)."""

    kind = Category.WALL

    def __init__(self, name: str, a: Point, b: Point, thickness: float = 0.01) -> None:
        super().__init__(name)
        self.a, self.b = _check_points(name, [a, b], 2)
        if thickness <= 0:
            raise ValueError(f"{name}: wall thickness must be > 0, got {thickness}")
        self.thickness = float(thickness)
        self.body = pymunk.Body(body_type=pymunk.Body.STATIC)
        shape = self._own(pymunk.Segment(self.body, self.a, self.b, self.thickness / 2))
        shape.friction = 0.3
        self.bodies = [self.body]

    @property
    def position(self) -> Point:
        return ((self.a[0] + self.b[0]) / 2, (self.a[1] + self.b[1]) / 2)

    def draw(self, canvas: Canvas) -> None:
        canvas.line([self.a, self.b], (40, 40, 40), canvas.stroke(self.thickness))


class Door(Wall):
    """A wall segment that can be opened (removed from collisions) and closed at run time."""

    kind = Category.DOOR

    def __init__(self, name: str, a: Point, b: Point, thickness: float = 0.01, is_open: bool = True) -> None:
        super().__init__(name, a, b, thickness)
        self.is_open = True
        self._closed_shapes = list(self.shapes)
        if not is_open:
            self.is_open = False
        else:
            self.shapes = []

    def open(self) -> None:
        if not self.is_open:
            if self.space is not None:
                self.space.remove(*self._closed_shapes)
            self.shapes = []
            self.is_open = True

    def close(self) -> bool:
        """Close the door; returns False (and stays open) when a solid object is in the way."""
        if not self.is_open:
            return True
        if self.space is not None:
            shape = self._closed_shapes[0]
            blocked = self.space.segment_query(self.a, self.b, self.thickness / 2, pymunk.ShapeFilter())
            if any(hit.shape.body.body_type == pymunk.Body.DYNAMIC for hit in blocked):
                return False
            self.space.add(shape)
        self.shapes = list(self._closed_shapes)
        self.is_open = False
        return True

    def draw(self, canvas: Canvas) -> None:
        if self.is_open:
            canvas.line([self.a, self.b], (120, 200, 120), 1)
        else:
            canvas.line([self.a, self.b], (150, 60, 40), canvas.stroke(self.thickness))


class StaticPolygon(Entity):
    """Furniture or a fixed obstacle: a static convex polygon (vertices in world metres)."""

    kind = Category.FURNITURE

    def __init__(self, name: str, vertices: Sequence[Point]) -> None:
        super().__init__(name)
        self.vertices = _check_points(name, vertices, 3)
        self.body = pymunk.Body(body_type=pymunk.Body.STATIC)
        shape = self._own(pymunk.Poly(self.body, self.vertices))
        shape.friction = 0.5
        self.bodies = [self.body]

    @property
    def position(self) -> Point:
        c = np.mean(np.asarray(self.vertices), axis=0)
        return (float(c[0]), float(c[1]))

    def draw(self, canvas: Canvas) -> None:
        canvas.polygon(self.vertices, (180, 180, 180), (90, 90, 90))


def regular_polygon(n_sides: int, radius: float, rotation: float = 0.0) -> list[Point]:
    """Vertices of a regular convex polygon centred on the origin."""
    angles = rotation + 2 * np.pi * np.arange(n_sides) / n_sides
    return [(radius * math.cos(a), radius * math.sin(a)) for a in angles]


class _DrivenBody(Entity):
    """A dynamic polygon held to a kinematic control body by force-limited joints.

    With the control body at rest and static this is ground friction (boxes); with the
    control body moving it is a scripted mover that still yields to large forces.
    """

    draw_layer = Layer.MOVING
    tracked = True
    #: Fill colour of the drawn polygon.
    fill: tuple[int, int, int]

    def __init__(
        self,
        name: str,
        vertices: Sequence[Point],
        position: Point,
        mass: float,
        max_force: float,
        max_torque: float,
        collides_with: int = SOLID,
    ) -> None:
        super().__init__(name)
        self.local_vertices = _check_points(name, vertices, 3)
        if not (mass > 0 and math.isfinite(mass)):
            raise ValueError(f"{name}: mass must be a finite number > 0, got {mass!r}")
        self.mass = float(mass)
        self.body = pymunk.Body(self.mass, pymunk.moment_for_poly(self.mass, self.local_vertices))
        self.body.position = position
        self.shape = self._own(pymunk.Poly(self.body, self.local_vertices), mask=collides_with)
        self.shape.friction = 0.4
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.position = position
        self.pivot = pymunk.PivotJoint(self.control, self.body, (0.0, 0.0), (0.0, 0.0))
        self.pivot.max_bias = 0.0
        self.pivot.max_force = max_force
        self.gear = pymunk.GearJoint(self.control, self.body, 0.0, 1.0)
        self.gear.max_bias = 0.0
        self.gear.max_force = max_torque
        self.bodies = [self.body, self.control]
        self.constraints = [self.pivot, self.gear]
        self._bounding_radius = max(math.hypot(x, y) for x, y in self.local_vertices)

    @property
    def bounding_radius(self) -> float:
        """Radius of the smallest origin-centred circle containing the polygon (m)."""
        return self._bounding_radius

    @property
    def velocity(self) -> Point:
        vx, vy = self.body.velocity
        return vx, vy

    def draw(self, canvas: Canvas) -> None:
        to_world = self.body.local_to_world
        canvas.polygon([to_world(v) for v in self.local_vertices], self.fill, (60, 30, 30))


class MovingPolygon(_DrivenBody):
    """A convex polygon moving on a scripted velocity, bouncing inside the arena.

    It is driven like a robot, through a force-limited joint, so a robot pinned against a
    wall stops it instead of being pushed through the wall. With ``bounce=False`` it keeps
    its scripted velocity for good: one straight line, leaving the arena when the line does.
    ``collides_with`` is the category mask of what it touches (default: everything solid).
    """

    kind = Category.OBSTACLE
    has_state_row = True
    fill = (220, 80, 80)

    def __init__(
        self,
        name: str,
        vertices: Sequence[Point],
        position: Point,
        velocity: Point,
        mass: float = 1.0,
        max_force: float = 5.0,
        bounce: bool = True,
        collides_with: int = SOLID,
    ) -> None:
        super().__init__(name, vertices, position, mass, max_force, max_force * 0.1, collides_with)
        self.bounce = bool(bounce)
        self.target_velocity = (float(velocity[0]), float(velocity[1]))
        self.control.velocity = self.target_velocity
        self.body.velocity = self.target_velocity

    def plan_bounce(self, bounds: tuple[float, float, float, float], dt: float, state: list[float] | None = None) -> None:
        """Reflect the scripted velocity if the next control step would leave ``bounds``.

        ``bounds`` is ``(x_min, y_min, x_max, y_max)`` of the free arena interior. Also
        reverses when the body was held back (moved less than half as far as scripted),
        e.g. by another obstacle. Does nothing for an obstacle made with ``bounce=False``.
        """
        if not self.bounce:
            return
        vx, vy = self.target_velocity
        if state is None:
            x, y = self.body.position
            actual_x, actual_y = self.body.velocity
        else:
            x, y, actual_x, actual_y = state[0], state[1], state[3], state[4]
        r = self._bounding_radius
        x_min, y_min, x_max, y_max = bounds
        if (x + vx * dt + r > x_max and vx > 0) or (x + vx * dt - r < x_min and vx < 0):
            vx = -vx
        if (y + vy * dt + r > y_max and vy > 0) or (y + vy * dt - r < y_min and vy < 0):
            vy = -vy
        if (vx, vy) == self.target_velocity and actual_x * vx + actual_y * vy < 0.25 * (vx * vx + vy * vy):
            vx, vy = -vx, -vy
        if (vx, vy) != self.target_velocity:
            self.target_velocity = (vx, vy)
            self.control.velocity = self.target_velocity

    def before_step(self, world: World, state: list[float]) -> None:
        """Plan the bounce off the arena ``[0, w] x [0, h]`` (see :meth:`plan_bounce`)."""
        self.plan_bounce((0.0, 0.0, world.size[0], world.size[1]), world.dt, state)


class Box(_DrivenBody):
    """A box with mass and Coulomb ground friction ``μ m g``.

    Ground friction is a pivot and a gear joint to a resting kinematic body with force limit
    ``μ m g`` and torque limit ``μ m g · (2/3) r_eq`` (r_eq: radius of the disc of equal
    area, the friction torque of a uniformly loaded disc). A robot moves the box only if
    its motor force exceeds the friction force.
    """

    kind = Category.BOX
    fill = (205, 170, 110)

    def __init__(
        self,
        name: str,
        size: tuple[float, float],
        position: Point,
        mass: float,
        ground_friction: float = 0.5,
        angle: float = 0.0,
    ) -> None:
        w, h = float(size[0]), float(size[1])
        if not (w > 0 and h > 0):
            raise ValueError(f"{name}: box size must be positive, got {size!r}")
        if not ground_friction >= 0:
            raise ValueError(f"{name}: ground friction must be >= 0, got {ground_friction!r}")
        vertices = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
        force = ground_friction * mass * GRAVITY
        r_eq = math.sqrt(w * h / math.pi)
        super().__init__(name, vertices, position, mass, force, force * 2.0 / 3.0 * r_eq)
        self.size = (w, h)
        self.ground_friction = float(ground_friction)
        self.body.angle = angle
        self.control.angle = angle

    @property
    def friction_force(self) -> float:
        """Force needed to slide the box, μ m g (N)."""
        return self.ground_friction * self.mass * GRAVITY


class Target(PointEntity):
    """A point of interest (goal, food item); it has no body and collides with nothing."""

    kind = Category.TARGET
    draw_layer = Layer.MARKS

    def __init__(self, name: str, position: Point, radius: float = 0.02) -> None:
        super().__init__(name, position)
        self.radius = float(radius)

    def draw(self, canvas: Canvas) -> None:
        canvas.cross(self.position, (200, 0, 0), self.radius)


class Lamp(PointEntity):
    """A point light source (paper 004's lamp); no body, collides with nothing.

    A :class:`~teamgym.sim.sensors.LightSensor` made with a lamp follows it when it moves.
    Drawn as a yellow disc of ``radius_px`` pixels.
    """

    kind = Category.LAMP
    draw_layer = Layer.LAMPS

    def __init__(self, name: str, position: Point, radius_px: float = 8.0) -> None:
        super().__init__(name, position)
        self.radius_px = float(radius_px)

    def draw(self, canvas: Canvas) -> None:
        canvas.disc(self.position, self.radius_px, (255, 220, 0), (120, 100, 0))
