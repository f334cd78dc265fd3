"""The primitive actions of paper 004 (section 3.1) as a per-robot executor.

The paper's actions are direction-change (turn 180°), push-clockwise, push-counterclockwise,
push-straight, turn-left, turn-right, go-ahead, stop (section 3.1), following and side&push
(section 3.4). A robot selects one every 100 ms action cycle (section 4). Most are one-cycle
motor commands; three describe motions that cannot fit in 100 ms and run as short programs
of in-place turns and straight drives, during which the robot is *busy* and further
selections are ignored until the program ends:

* ``DIRECTION_CHANGE``: turn in place by 180° (± a uniform jitter, the imprecision of a real
  turn that keeps a wandering robot from retracing one line forever), towards the freer side.
* ``FOLLOW_*``: "moves to the direction in which another robot was sensed or left"
  (section 3.4). The direction is one of the paper's four sensor groups (forward, left,
  right, back; section 3.1), so following is four primitives: turn to face that direction
  (forward: the nearest front reading, if any) and drive ``follow_step`` forward.
* ``SIDE_AND_PUSH``: "aligned robots move to side and push a box" (section 3.4, Fig. 7):
  turn 90° towards the freer side, drive ``side_offset`` (one robot diameter plus a gap),
  turn back and drive forward until something is within ``contact_distance`` ahead.

Pushing is closed-loop on the front rays, as a Khepera would push: ``PUSH_STRAIGHT`` steers
to keep the pushed object centred ahead (``centring_gain``; open-loop a box slides off the
round robot). Push-clockwise and push-counterclockwise (Fig. 5 is missing) rotate the box by
pushing it off-centre: the robot holds the object ``push_offset`` to one side of its axis,
so the box turns and the robot turns with it. B-3 pairs them with the light on the left, B-5
with the light on the right; only if the paper counts rotation clockwise-positive (as paper
001 counts its angles, see docs/simulator.md) do both rules turn the box towards the lamp,
which is the task. We read it so: ``PUSH_CLOCKWISE`` turns box and robot to the robot's left
(counter-clockwise seen from above in teamgym's frame), ``PUSH_COUNTERCLOCKWISE`` to its
right. ``tests/envs/test_box_pushing_physics.py`` checks both senses.

Progress of programs is measured by odometry from the wheel encoders, as on the Khepera.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

#: Proximity ray indices per sensor group, paper 004 section 3.1 (Fig. 3 numbering).
FORWARD_RAYS = (1, 2, 3, 4)
LEFT_RAYS = (0,)
RIGHT_RAYS = (5,)
BACK_RAYS = (6, 7)


class Primitive(IntEnum):
    """The discrete action set (paper 004, sections 3.1 and 3.4); values are action indices."""

    DIRECTION_CHANGE = 0
    PUSH_CLOCKWISE = 1
    PUSH_COUNTERCLOCKWISE = 2
    PUSH_STRAIGHT = 3
    TURN_LEFT = 4
    TURN_RIGHT = 5
    GO_AHEAD = 6
    STOP = 7
    FOLLOW_FORWARD = 8
    FOLLOW_LEFT = 9
    FOLLOW_RIGHT = 10
    FOLLOW_BACK = 11
    SIDE_AND_PUSH = 12


@dataclass(frozen=True)
class PrimitiveParams:
    """Speeds (m/s), rates (rad/s), angles (rad) and distances (m) of the primitives."""

    dt: float = 0.1
    cruise_speed: float = 0.1
    push_speed: float = 0.08
    follow_speed: float = 0.1
    turn_rate: float = 5.0
    turn_step: float = math.radians(30.0)
    centring_gain: float = 20.0
    push_offset: float = 0.01
    direction_change_jitter: float = math.radians(30.0)
    side_offset: float = 0.07
    approach_distance: float = 0.12
    follow_step: float = 0.01
    contact_distance: float = 0.02
    sensor_range: float = 0.1
    ray_angles: tuple[float, ...] = ()
    wheel_radius: float = 0.008
    wheel_base: float = 0.053


@dataclass
class _Segment:
    """One part of a program: an in-place turn by ``amount`` rad or a straight drive of ``amount`` m."""

    kind: str  # "turn" or "drive"
    amount: float
    speed: float = 0.0
    until_contact: bool = False
    done: float = 0.0
    cycles: int = 0
    limit: int = 0


class PrimitiveExecutor:
    """Turns a robot's selected primitives into motor commands ``(v, ω)``, one per cycle.

    Call :meth:`observe` after every control step with the robot's new proximity readings and
    wheel-encoder rotations (rad), then :meth:`command` with the next selected primitive.
    """

    def __init__(self, params: PrimitiveParams) -> None:
        self.params = params
        self._program: list[_Segment] = []
        self._proximity = np.full(max(8, len(params.ray_angles)), params.sensor_range)
        self.current: Primitive | None = None

    @property
    def busy(self) -> bool:
        """Whether a multi-cycle primitive is running (the next selection will be ignored)."""
        return bool(self._program)

    def observe(self, proximity: np.ndarray, encoders: tuple[float, float, float, float]) -> None:
        """Credit the last cycle's motion (actual wheel rotations) to the running program."""
        self._proximity = proximity
        if not self._program:
            return
        p = self.params
        left, right = encoders[2] * p.wheel_radius, encoders[3] * p.wheel_radius
        segment = self._program[0]
        segment.cycles += 1
        if segment.kind == "turn":
            segment.done += (right - left) / p.wheel_base * math.copysign(1.0, segment.amount)
            finished = segment.done >= abs(segment.amount) - math.radians(2.0)
        else:
            step = 0.5 * (left + right)
            segment.done += step
            blocked = step < 0.1 * segment.speed * p.dt
            contact = segment.until_contact and self._front_gap() < p.contact_distance
            finished = segment.done >= segment.amount - 1e-4 or contact or blocked
        if finished or segment.cycles >= segment.limit:
            self._program.pop(0)
        if not self._program:
            self.current = None

    def command(self, action: int, rng: np.random.Generator | None = None) -> tuple[float, float]:
        """The ``(v, ω)`` for this cycle: the running program's, else that of primitive ``action``."""
        if not self._program:
            self._start(Primitive(action), rng)
        if not self._program:
            return self._one_cycle(self.current)
        return self._segment_command(self._program[0])

    def cancel(self) -> None:
        """Abandon a running program (the robot broke down or left)."""
        self._program = []
        self.current = None

    # -- internals --------------------------------------------------------------------------
    def _start(self, primitive: Primitive, rng: np.random.Generator | None) -> None:
        p = self.params
        self.current = primitive
        if primitive is Primitive.DIRECTION_CHANGE:
            jitter = p.direction_change_jitter * (float(rng.uniform(-1.0, 1.0)) if rng is not None else 0.0)
            self._program = [self._turn(self._freer_side() * (math.pi + jitter))]
        elif primitive is Primitive.SIDE_AND_PUSH:
            side = self._freer_side()
            self._program = [
                self._turn(side * math.pi / 2),
                self._drive(p.side_offset, p.cruise_speed),
                self._turn(-side * math.pi / 2),
                self._drive(p.approach_distance, p.push_speed, until_contact=True),
            ]
        elif primitive in (Primitive.FOLLOW_FORWARD, Primitive.FOLLOW_LEFT, Primitive.FOLLOW_RIGHT, Primitive.FOLLOW_BACK):
            bearing = self._follow_bearing(primitive)
            program = [self._turn(bearing)] if abs(bearing) > math.radians(5.0) else []
            self._program = [*program, self._drive(p.follow_step, p.follow_speed, until_contact=True)]

    def _one_cycle(self, primitive: Primitive) -> tuple[float, float]:
        p = self.params
        if primitive is Primitive.PUSH_STRAIGHT:
            return p.push_speed, self._centring()
        if primitive is Primitive.PUSH_CLOCKWISE:
            return p.push_speed, self._centring(p.push_offset)
        if primitive is Primitive.PUSH_COUNTERCLOCKWISE:
            return p.push_speed, self._centring(-p.push_offset)
        if primitive is Primitive.TURN_LEFT:
            return 0.0, p.turn_step / p.dt
        if primitive is Primitive.TURN_RIGHT:
            return 0.0, -p.turn_step / p.dt
        if primitive is Primitive.GO_AHEAD:
            return p.cruise_speed, 0.0
        return 0.0, 0.0

    def _segment_command(self, segment: _Segment) -> tuple[float, float]:
        p = self.params
        if segment.kind == "turn":
            remaining = max(0.0, abs(segment.amount) - segment.done)
            return 0.0, math.copysign(min(p.turn_rate, remaining / p.dt), segment.amount)
        return segment.speed, 0.0

    def _turn(self, angle: float) -> _Segment:
        nominal = abs(angle) / (self.params.turn_rate * self.params.dt)
        return _Segment("turn", angle, limit=int(3 * nominal) + 3)

    def _drive(self, distance: float, speed: float, until_contact: bool = False) -> _Segment:
        nominal = distance / (speed * self.params.dt)
        return _Segment("drive", distance, speed, until_contact, limit=int(3 * nominal) + 3)

    def _group_min(self, rays: tuple[int, ...]) -> float:
        return float(min(self._proximity[i] for i in rays))

    def _centring(self, offset: float = 0.0) -> float:
        """Turn rate that keeps the pushed object centred ahead: towards the side whose front rays read nearer."""
        prox, reach = self._proximity, self.params.sensor_range
        left = min(prox[1], prox[2], reach)
        right = min(prox[3], prox[4], reach)
        return float(np.clip(self.params.centring_gain * (right - left - offset), -self.params.turn_rate, self.params.turn_rate))

    def _front_gap(self) -> float:
        return self._group_min((2, 3))

    def _freer_side(self) -> float:
        """+1 (left) unless the right side has more free space than the left."""
        left = min(self._proximity[0], self._proximity[1])
        right = min(self._proximity[4], self._proximity[5])
        return -1.0 if right > left else 1.0

    def _follow_bearing(self, primitive: Primitive) -> float:
        if primitive is Primitive.FOLLOW_LEFT:
            return math.pi / 2
        if primitive is Primitive.FOLLOW_RIGHT:
            return -math.pi / 2
        if primitive is Primitive.FOLLOW_BACK:
            return math.pi if self._proximity[7] <= self._proximity[6] else -math.pi
        rays = FORWARD_RAYS
        nearest = min(rays, key=lambda i: self._proximity[i])
        if self._proximity[nearest] >= self.params.sensor_range or not self.params.ray_angles:
            return 0.0
        return float(self.params.ray_angles[nearest])
