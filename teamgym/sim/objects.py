"""Passive objects: walls, doors, static and moving convex polygons, boxes, targets, lamps."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pymunk

from teamgym.sim.canvas import Canvas, Layer
from teamgym.sim.categories import SOLID, Category
from teamgym.sim.entity import Entity, PointEntity, StepGroup

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
    fixed = True

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
    fixed = False

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
    fixed = True

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


#: Friction coefficient of the surface of boxes and moving polygons (contacts multiply the two surfaces' values).
SURFACE_FRICTION = 0.4

#: Share of a body's mass carried by its support feet (:func:`add_support_feet`).
FOOT_MASS_SHARE = 0.5

#: Ground models of boxes: ``"joint"`` (one force and one torque limit) or support feet laid out by :func:`footprint_support`.
SUPPORT_LAYOUTS = ("joint", "corners", "perimeter", "area")


def footprint_support(size: tuple[float, float], layout: str, n: int = 3) -> list[Point]:
    """Support points of a ``w × h`` rectangle centred on the origin, in its local frame.

    ``"corners"``: the four corners (a box standing on four feet). ``"perimeter"``: ``n``
    points per side at the centres of ``n`` equal segments (a box of boards resting on
    their lower edges). ``"area"``: the centres of an ``n × n`` grid of equal cells (uniform
    pressure over the footprint).
    """
    w, h = float(size[0]), float(size[1])
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"footprint_support: n must be an int >= 1, got {n!r}")
    cells = (np.arange(n) + 0.5) / n - 0.5
    if layout == "corners":
        return [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
    if layout == "perimeter":
        points = [(float(t * w), -h / 2) for t in cells] + [(w / 2, float(t * h)) for t in cells]
        return points + [(float(-t * w), h / 2) for t in cells] + [(-w / 2, float(-t * h)) for t in cells]
    if layout == "area":
        return [(float(x * w), float(y * h)) for y in cells for x in cells]
    raise ValueError(f"footprint_support: layout must be one of 'corners', 'perimeter', 'area', got {layout!r}")


def push_threshold(points: Sequence[Point], at: Point, direction: Point) -> float:
    """Smallest force that slides a body resting on ``points`` when pushed at ``at`` along ``direction``.

    In units of the total friction ``μ m g``, the weight shared equally by the support
    points (local frame, as ``at``). The friction wrenches ``(f_x, f_y, τ)`` the support can
    exert form a convex set whose boundary is the limit surface (Goyal, Ruina and
    Papadopoulos 1991); the push ``λ·(u, at × u)`` first leaves it at
    ``λ = min_q h(q) / (q · d)``, where ``h(q) = Σ_i |(q_x − q_τ y_i, q_y + q_τ x_i)| / k`` is
    the set's support function. Minimised over ``q`` on a sphere grid, then refined.
    """
    pts = np.asarray(points, dtype=float)
    ux, uy = direction
    norm = math.hypot(ux, uy)
    d = np.array([ux / norm, uy / norm, (at[0] * uy - at[1] * ux) / norm])

    def ratio(q: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(q)
        gx = q[:, :1] - q[:, 2:] * pts[:, 1]
        gy = q[:, 1:2] + q[:, 2:] * pts[:, 0]
        along = q @ d
        return np.where(along > 1e-12, np.hypot(gx, gy).mean(axis=1) / np.maximum(along, 1e-12), np.inf)

    scale = max(float(np.abs(pts).max()), 1e-9)  # torque rows scaled to the body's size
    n = 4000
    z = 1 - (2 * np.arange(n) + 1) / n
    phi = np.arange(n) * math.pi * (3 - math.sqrt(5))
    grid = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z / scale], axis=1)
    values = ratio(grid)
    best = grid[int(np.argmin(values))]
    value = float(values.min())
    step = 0.05
    for _ in range(200):
        trial = best + step * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1 / scale], [0, 0, -1 / scale]])
        values = ratio(trial)
        k = int(np.argmin(values))
        if values[k] < value:
            best, value = trial[k], float(values[k])
        else:
            step /= 2
            if step < 1e-7:
                break
    return value


def weakest_push(points: Sequence[Point], size: tuple[float, float], contact_friction: float) -> float:
    """The smallest :func:`push_threshold` of one pusher on a face of a ``w × h`` box (units of ``μ m g``).

    The pusher may touch any point of the ``x = -w/2`` face or its corner and push along the
    face normal tilted by up to the contact's friction angle, or touch the corner and push
    between the two face normals; by symmetry this covers every face. The worst case is a
    push at a corner (docs/box_pushing.md).
    """
    w, h = float(size[0]), float(size[1])
    tilt = math.atan(max(contact_friction, 0.0))
    worst = math.inf
    for e in np.linspace(0.0, h / 2, 5):
        for a in (-tilt, 0.0, tilt):
            worst = min(worst, push_threshold(points, (-w / 2, float(e)), (math.cos(a), math.sin(a))))
    for a in np.linspace(-math.pi / 2 - tilt, tilt, 13):
        worst = min(worst, push_threshold(points, (-w / 2, h / 2), (math.cos(a), math.sin(a))))
    return worst


def add_support_feet(
    body: pymunk.Body,
    ground: pymunk.Body,
    points: Sequence[Point],
    foot_mass: float,
    max_force: float,
) -> tuple[list[pymunk.Body], list[pymunk.Constraint], list[pymunk.PivotJoint]]:
    """Planar Coulomb friction at support points: one *foot* per point, pinned to ``body``.

    Each foot is a point mass (no rotational inertia) at a support point, held to ``body``
    by a stiff pivot joint and to ``ground`` (a kinematic body: at rest for table friction,
    moving for a wheel's drive) by a pivot joint with ``max_bias = 0`` and ``max_force`` —
    a velocity constraint whose impulse is clamped to a disc, i.e. Coulomb friction
    ``|f_i| ≤ max_force`` at that point, opposing its sliding. Sliding and turning are then
    coupled as on a real table (the limit surface of the support points): an off-centre
    push turns a sliding body. Why feet: Chipmunk clamps each joint's accumulated impulse to
    a disc in the plain Euclidean norm; a joint anchored directly on the body has an
    anisotropic effective mass (its lever arm couples rotation) and the solver then settles
    on forces that are not Coulomb's (with 12 points a pure push slid the body at 0.93 μmg).
    A foot without rotational inertia has an isotropic effective mass, and the thresholds
    measured in simulation match the limit surface to 0.2 % (``docs/box_pushing.md``).

    Returns the feet, every new constraint (pins and ground joints, for the space) and the
    ground joints (in the order of ``points``); the ground joints' anchors on ``ground`` are
    at its origin (set them for a moving ``ground``). ``body``'s mass is not changed: give it
    the rest of the total mass.
    """
    feet, constraints, grips = [], [], []
    for x, y in points:
        foot = pymunk.Body(foot_mass, math.inf)
        foot.position = body.local_to_world((x, y))
        pin = pymunk.PivotJoint(body, foot, (x, y), (0.0, 0.0))
        grip = pymunk.PivotJoint(ground, foot, (0.0, 0.0), (0.0, 0.0))
        grip.max_bias = 0.0
        grip.max_force = max_force
        feet.append(foot)
        constraints += [pin, grip]
        grips.append(grip)
    return feet, constraints, grips


def place_feet(body: pymunk.Body, feet: Sequence[pymunk.Body], points: Sequence[Point]) -> None:
    """Put ``feet`` back under ``body`` at their support ``points`` (after moving ``body``), at ``body``'s velocity."""
    for foot, point in zip(feet, points):
        foot.position = body.local_to_world(point)
        foot.velocity = body.velocity_at_local_point(point)


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
        self.shape.friction = SURFACE_FRICTION
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

    @classmethod
    def step_group(cls, entities: list[Entity], world: World) -> StepGroup:
        """:class:`BounceSteps` when the class keeps these hooks (else the entity-by-entity default)."""
        own = all(getattr(cls, name) is getattr(MovingPolygon, name) for name in ("before_step", "plan_bounce", "after_step"))
        return BounceSteps(entities) if own else super().step_group(entities, world)


class BounceSteps(StepGroup):
    """:meth:`MovingPolygon.before_step` of a run of moving polygons: each plans its bounce (none asks for a mid-step call)."""

    def before(self, world: World, rows: list[list[float]], block: np.ndarray) -> list[tuple[float, Entity]]:
        bounds, dt = (0.0, 0.0, world.size[0], world.size[1]), world.dt
        for obstacle, row in zip(self.entities, rows):
            if obstacle.bounce:
                obstacle.plan_bounce(bounds, dt, row)
        return []

    def after(self, world: World, starts: list[list[float]], ends: list[list[float]]) -> None:
        """Nothing: a moving polygon has no ``after_step``."""


class Box(_DrivenBody):
    """A box with mass and Coulomb ground friction ``μ m g``.

    ``support="joint"`` (the default, ``BoxPushing-v0``): ground friction is a pivot and a
    gear joint to a resting kinematic body with force limit ``μ m g`` and torque limit
    ``μ m g · (2/3) r_eq`` (r_eq: radius of the disc of equal area, the friction torque of a
    uniformly loaded disc). Sliding and turning are resisted independently: a box pushed
    hard enough to slide turns only if the push's torque alone exceeds the torque limit.

    ``support="corners"``, ``"perimeter"`` or ``"area"``: planar Coulomb friction at the
    support points of :func:`footprint_support` (``support_n`` = ``n``), each carrying an
    equal share of the weight, ``μ m g / k`` (:func:`add_support_feet`; half of the mass
    sits in the feet). Sliding and turning share the friction (the limit surface), so an
    off-centre push turns a sliding box. In both models a robot moves the box only if its
    push lies outside the friction limits.
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
        support: str = "joint",
        support_n: int = 3,
    ) -> None:
        w, h = float(size[0]), float(size[1])
        if not (w > 0 and h > 0):
            raise ValueError(f"{name}: box size must be positive, got {size!r}")
        if not ground_friction >= 0:
            raise ValueError(f"{name}: ground friction must be >= 0, got {ground_friction!r}")
        if support not in SUPPORT_LAYOUTS:
            raise ValueError(f"{name}: support must be one of {SUPPORT_LAYOUTS}, got {support!r}")
        vertices = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
        force = ground_friction * mass * GRAVITY
        r_eq = math.sqrt(w * h / math.pi)
        super().__init__(name, vertices, position, mass, force, force * 2.0 / 3.0 * r_eq)
        self.size = (w, h)
        self.ground_friction = float(ground_friction)
        self.support = support
        self.body.angle = angle
        self.control.angle = angle
        #: Support points (local), their feet and the feet's ground joints; empty for ``"joint"``.
        self.support_points: list[Point] = []
        self.feet: list[pymunk.Body] = []
        self.grips: list[pymunk.PivotJoint] = []
        if support != "joint":
            self.support_points = footprint_support((w, h), support, support_n)
            k = len(self.support_points)
            carried = self.mass * (1.0 - FOOT_MASS_SHARE)
            self.body.mass = carried
            self.body.moment = pymunk.moment_for_poly(carried, self.local_vertices)
            self.feet, self.constraints, self.grips = add_support_feet(
                self.body, self.control, self.support_points, self.mass * FOOT_MASS_SHARE / k, force / k
            )
            self.bodies = [self.body, self.control, *self.feet]
            self.pivot = self.gear = None

    @property
    def friction_force(self) -> float:
        """Force needed to slide the box, μ m g (N)."""
        return self.ground_friction * self.mass * GRAVITY

    def teleport(self, position: Point, angle: float | None = None) -> None:
        """Place the box (and its ground anchor and feet) at rest."""
        for body in (self.body, self.control):
            body.position = position
            if angle is not None:
                body.angle = angle
            body.velocity = (0.0, 0.0)
            body.angular_velocity = 0.0
        place_feet(self.body, self.feet, self.support_points)
        if self.space is not None:
            self.space.reindex_shapes_for_body(self.body)


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
