"""Differential-drive robots driven through limited motor forces.

Drive model
-----------
A robot is a dynamic disc. It is not moved by setting its velocity: a kinematic *control
body* is joined to it by a pivot joint and a gear joint, both with ``max_bias = 0``
(velocity constraints only) and a ``max_force`` equal to the motors' force and torque
limits. This is pymunk's top-down friction technique: the robot follows the commanded
motion unless something resists harder than its motors can push, so robots push light
boxes, stall against heavy ones and are stopped by walls instead of teleporting.

Ground contact (``RobotSpec.ground_contact``): ``"centre"`` (the default) is the pivot and
gear pair above, a force limit and an independent torque limit. ``"wheels"`` holds each
wheel's contact point to the commanded motion with half the motor force (one support foot
per wheel, :func:`teamgym.sim.objects.add_support_feet`): the same planar Coulomb model as
a box's support points, so a push off the robot's centre line turns it as well as shoving
it (a push along the heading at one wheel meets one wheel's motor, half the force).

To make the robot follow the exact arc of a constant command ``(v, ω)`` over a control step
without Python work in every physics substep, the control body is placed at the
instantaneous centre of curvature and spun at ω; the pivot's anchor on the control body is
the robot's position, so the anchor travels along the arc with speed ``v`` (for ``ω ≈ 0``
the control body simply translates with ``v``).

Wheel kinematics, paper 001 eq. (6)
-----------------------------------
The paper writes ``v_L = v + (L/2) ω`` and ``v_R = v − (L/2) ω``; with its obstacle heading
of eq. (4), ``arctan(Δx / Δy)``, angles there are measured clockwise from the y-axis, so a
positive ω turns right. teamgym uses the usual counter-clockwise convention (θ from the
x-axis, positive ω turns left), in which eq. (6) reads ``v_L = v − (L/2) ω`` and
``v_R = v + (L/2) ω``; :func:`wheel_speeds` implements this form.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
import pymunk

from teamgym.sim.canvas import Canvas, Layer, robot_colour
from teamgym.sim.categories import RAY_HITS, Category
from teamgym.sim.chipmunk import kinematic_setters, set_pivot_anchor_a
from teamgym.sim.entity import Entity, StepGroup
from teamgym.sim.objects import FOOT_MASS_SHARE, add_support_feet, place_feet

if TYPE_CHECKING:
    from teamgym.sim.world import World

_group_ids = itertools.count(1)
_set_position, _set_angle, _set_velocity, _set_angular_velocity = kinematic_setters()

#: Runs of at least this many robots set their control bodies in one numpy pass and one
#: ``pymunk.batch`` write (:class:`RobotSteps`); shorter runs robot by robot (cheaper below it).
BULK_ROBOTS = 8


@dataclass(frozen=True)
class RobotSpec:
    """Physical parameters of a differential-drive robot (SI units).

    Defaults describe a Khepera: 55 mm diameter, 53 mm wheel base, about 80 g. The motor
    force limit (0.6 N) lets one robot push a 50 g box with ground friction coefficient 0.5
    (friction 0.25 N) but not a 200 g one (0.98 N), which two robots (1.2 N) can move together.
    """

    radius: float = 0.0275
    wheel_base: float = 0.053
    wheel_radius: float = 0.008
    max_wheel_speed: float = 0.4
    mass: float = 0.08
    max_motor_force: float = 0.6
    friction: float = 0.4
    elasticity: float = 0.0
    ground_contact: Literal["centre", "wheels"] = "centre"

    def __post_init__(self) -> None:
        for field in ("radius", "wheel_base", "wheel_radius", "max_wheel_speed", "mass", "max_motor_force"):
            value = getattr(self, field)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"RobotSpec.{field} must be a finite number > 0, got {value!r}")
        if self.ground_contact not in ("centre", "wheels"):
            raise ValueError(f"RobotSpec.ground_contact must be 'centre' or 'wheels', got {self.ground_contact!r}")
        if self.wheel_base > 2 * self.radius:
            raise ValueError(f"RobotSpec.wheel_base ({self.wheel_base}) cannot exceed the robot's diameter ({2 * self.radius})")

    @property
    def max_speed(self) -> float:
        """Largest linear speed (both wheels at their limit)."""
        return self.max_wheel_speed

    @property
    def max_turn_rate(self) -> float:
        """Largest angular speed (wheels at opposite limits), rad/s."""
        return 2.0 * self.max_wheel_speed / self.wheel_base

    @property
    def max_motor_torque(self) -> float:
        """Torque limit: each wheel pushes with half the force at lever arm L/2."""
        return self.max_motor_force * self.wheel_base / 2.0


def wheel_speeds(v: float, omega: float, wheel_base: float) -> tuple[float, float]:
    """Wheel rim speeds ``(v_L, v_R)`` for a body command ``(v, ω)``; eq. (6) of paper 001, CCW form."""
    half = 0.5 * wheel_base * omega
    return v - half, v + half


def body_command(v_left: float, v_right: float, wheel_base: float) -> tuple[float, float]:
    """Inverse of :func:`wheel_speeds`: ``(v, ω)`` from wheel rim speeds."""
    return 0.5 * (v_left + v_right), (v_right - v_left) / wheel_base


def saturate(v: float, omega: float, spec: RobotSpec) -> tuple[float, float]:
    """Scale ``(v, ω)`` so that no wheel exceeds ``spec.max_wheel_speed``.

    Both wheel speeds are scaled by the same factor, which keeps the curvature ω / v of
    the commanded arc.
    """
    v_left, v_right = wheel_speeds(v, omega, spec.wheel_base)
    peak = max(abs(v_left), abs(v_right))
    if peak > spec.max_wheel_speed:
        scale = spec.max_wheel_speed / peak
        return v * scale, omega * scale
    return v, omega


def set_commands(robots: Sequence[DiffDriveRobot], commands: np.ndarray) -> None:
    """:meth:`DiffDriveRobot.set_command` of each robot with its row ``(v, ω)`` of ``commands``, saturated in one pass.

    The operations of :func:`saturate` on arrays (same order, same bits); a robot that is not
    enabled gets ``(0, 0)``. A row that is not finite raises as :meth:`~DiffDriveRobot.set_command`
    does, before any robot is commanded.
    """
    commands = np.asarray(commands, dtype=float).reshape(-1, 2)
    if not np.isfinite(commands).all():
        bad = int(np.flatnonzero(~np.isfinite(commands).all(axis=1))[0])
        robots[bad].set_command(*commands[bad].tolist())  # raises the one-line error
    v, omega = commands[:, 0], commands[:, 1]
    half = 0.5 * np.array([robot.spec.wheel_base for robot in robots]) * omega
    peak = np.maximum(np.abs(v - half), np.abs(v + half))
    top = np.array([robot.spec.max_wheel_speed for robot in robots])
    over = peak > top
    if over.any():
        scale = np.divide(top, peak, out=np.ones_like(peak), where=over)
        v, omega = np.where(over, v * scale, v), np.where(over, omega * scale, omega)
    for robot, v_i, omega_i in zip(robots, v.tolist(), omega.tolist()):
        robot.command = (v_i, omega_i) if robot.enabled else (0.0, 0.0)


def scale_wheel_speeds(robots: Sequence[DiffDriveRobot], scale: np.ndarray) -> None:
    """Scale each robot's commanded wheel speeds by its row ``(left, right)`` of ``scale`` (motor noise): its
    command through :func:`wheel_speeds`, the scaled speeds back through :func:`body_command`, then
    :func:`set_commands` — the operations of the scalar functions on arrays, the same bits."""
    commands = np.array([robot.command for robot in robots], dtype=float).reshape(-1, 2)
    base = np.array([robot.spec.wheel_base for robot in robots])
    left, right = wheel_speeds(commands[:, 0], commands[:, 1], base)
    set_commands(robots, np.stack(body_command(left * scale[:, 0], right * scale[:, 1], base), axis=1))


@dataclass
class EncoderReading:
    """Wheel rotation over the last control step, in radians of wheel angle.

    ``commanded_*`` is what the motors were asked to turn, ``actual_*`` what the wheels
    turned given the robot's real motion. A robot pushing something immovable shows
    commanded rotation with almost no actual rotation (paper 004's "no rotation" fact).
    """

    commanded_left: float = 0.0
    commanded_right: float = 0.0
    actual_left: float = 0.0
    actual_right: float = 0.0
    #: Total actual rotation of each wheel since the robot was made, this step included (rad).
    total_left: float = 0.0
    total_right: float = 0.0

    @property
    def slip(self) -> float:
        """Fraction of commanded rotation that did not happen (0 = none lost, 1 = stalled)."""
        return wheel_slip(self.commanded_left, self.commanded_right, self.actual_left, self.actual_right)


#: A float, or a numpy array of one value per robot.
FloatOrArray = float | np.ndarray


def wheel_slip(commanded_left: float, commanded_right: float, actual_left: float, actual_right: float) -> float:
    """:attr:`EncoderReading.slip` of these wheel rotations (one formula for readings and raw encoder rows)."""
    commanded = abs(commanded_left) + abs(commanded_right)
    if commanded < 1e-12:
        return 0.0
    lost = abs(commanded_left - actual_left) + abs(commanded_right - actual_right)
    return min(1.0, lost / commanded)


def wheel_slips(rows: np.ndarray) -> np.ndarray:
    """:func:`wheel_slip` of every row of ``rows`` ``(commanded left, commanded right, actual left, actual right, ...)``."""
    commanded = np.abs(rows[:, 0]) + np.abs(rows[:, 1])
    lost = np.abs(rows[:, 0] - rows[:, 2]) + np.abs(rows[:, 1] - rows[:, 3])
    moving = commanded >= 1e-12
    slip = np.zeros(len(rows))
    np.divide(lost, commanded, out=slip, where=moving)
    return np.minimum(slip, 1.0)


class DiffDriveRobot(Entity):
    """A disc-shaped differential-drive robot with force-limited motors and wheel encoders.

    Drawn in the colour of its index among the robots drawn in the same frame (grey once
    disabled), with a white line showing its heading.
    """

    kind = Category.ROBOT
    draw_layer = Layer.ROBOTS
    tracked = True
    has_state_row = True

    def __init__(
        self,
        name: str,
        position: tuple[float, float],
        angle: float = 0.0,
        spec: RobotSpec | None = None,
    ) -> None:
        super().__init__(name)
        self.spec = spec or RobotSpec()
        s = self.spec
        self.group = next(_group_ids)
        #: Filter for this robot's own sensors: sees every solid except the robot itself.
        self.sensor_filter = pymunk.ShapeFilter(group=self.group, mask=RAY_HITS)
        wheels = s.ground_contact == "wheels"
        carried = s.mass * (1.0 - FOOT_MASS_SHARE) if wheels else s.mass
        moment = pymunk.moment_for_circle(carried, 0.0, s.radius)
        self.body = pymunk.Body(carried, moment)
        self.body.position = position
        self.body.angle = angle
        shape = self._own(pymunk.Circle(self.body, s.radius), group=self.group)
        shape.friction = s.friction
        shape.elasticity = s.elasticity
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.position = position
        self.control.angle = angle
        #: ``"wheels"`` ground contact: wheel contact points (left, right; local), their feet and drive joints.
        self.wheel_points: list[tuple[float, float]] = []
        self.wheels: list[pymunk.Body] = []
        self.drives: list[pymunk.PivotJoint] = []
        if wheels:
            half = s.wheel_base / 2
            self.wheel_points = [(0.0, half), (0.0, -half)]
            self.wheels, self.constraints, self.drives = add_support_feet(
                self.body, self.control, self.wheel_points, s.mass * FOOT_MASS_SHARE / 2, s.max_motor_force / 2
            )
            self.pivot = self.gear = None
            self.bodies = [self.body, self.control, *self.wheels]
        else:
            self.pivot = pymunk.PivotJoint(self.control, self.body, (0.0, 0.0), (0.0, 0.0))
            self.pivot.max_bias = 0.0
            self.pivot.max_force = s.max_motor_force
            self.gear = pymunk.GearJoint(self.control, self.body, 0.0, 1.0)
            self.gear.max_bias = 0.0
            self.gear.max_force = s.max_motor_torque
            self.bodies = [self.body, self.control]
            self.constraints = [self.pivot, self.gear]
        self.command = (0.0, 0.0)
        self.applied_command = (0.0, 0.0)
        self.actuation_delay = 0.0
        self.given_commands: tuple[tuple[float, float], ...] = ()  # newest last; see lag_commands
        self._encoder_values = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self.odometer = 0.0
        self.enabled = True
        self._start_pose = (float(position[0]), float(position[1]), float(angle))

    # -- commands -------------------------------------------------------------------
    def set_command(self, v: float, omega: float) -> None:
        """Command linear speed ``v`` (m/s) and angular speed ``ω`` (rad/s, CCW positive).

        The command is saturated at the wheel-speed limit (see :func:`saturate`) and takes
        effect at the next call of :meth:`apply_command` (the world does this at the start
        of a control step or of a delay phase).
        """
        if not (math.isfinite(v) and math.isfinite(omega)):
            raise ValueError(f"robot {self.name!r}: command must be finite, got v={v!r}, omega={omega!r}")
        if not self.enabled:
            v, omega = 0.0, 0.0
        self.command = saturate(float(v), float(omega), self.spec)

    def set_wheel_speeds(self, v_left: float, v_right: float) -> None:
        """Command the wheel rim speeds directly (m/s), converted by eq. (6) of paper 001."""
        self.set_command(*body_command(v_left, v_right, self.spec.wheel_base))

    def lag_commands(self, given: tuple[float, float], delay: float, dt: float, depth: int) -> None:
        """Set up this control step to follow the given commands ``delay`` s late, ``delay`` possibly above Δt.

        Paper 001, section 6.1 (true delay T0_true), carried past one step with a command
        queue: the command given at t_j acts from t_j + ``delay`` on. With ``delay`` = m·Δt + r
        (m whole steps, 0 ≤ r < Δt), step n (from t_n) runs the command given at t_{n−m−1} for
        r seconds, then the one given at t_{n−m} (before the first command: (0, 0)). For m = 0
        that is the one-step model (previous command for r, then ``given``). ``given`` is this
        step's command; the last ``depth`` (≥ m + 2) are kept in ``given_commands``. Sets
        ``applied_command``, ``command`` (what the world runs; the world splits the step at
        ``actuation_delay`` = r).
        """
        steps = math.floor(delay / dt + 1e-9)
        if depth < steps + 2:
            raise ValueError(f"robot {self.name!r}: a delay of {delay!r} s needs depth >= {steps + 2}, got {depth}")
        queue = (*self.given_commands, given)[-depth:]
        self.given_commands = queue
        rest = delay - steps * dt
        first, second = (len(queue) - steps - 2, len(queue) - steps - 1)
        self.applied_command = queue[first] if first >= 0 else (0.0, 0.0)
        self.command = queue[second] if second >= 0 else (0.0, 0.0)
        self.actuation_delay = rest if rest > 1e-9 * dt else 0.0

    def apply_command(self, command: tuple[float, float] | None = None, state: list[float] | None = None) -> None:
        """Re-anchor the control body so that the robot follows the arc of ``command``.

        ``state`` optionally gives the body's current ``(x, y, angle, ...)``.
        """
        v, omega = self.command if command is None else command
        if state is None:
            x, y = self.body.position
            theta = self.body.angle
        else:
            x, y, theta = state[0], state[1], state[2]
        handle = self.control._body  # Chipmunk's setters, in the order of pymunk.batch's writes
        if abs(omega) < 1e-9:
            _set_position(handle, (x, y))
            _set_angle(handle, theta)
            _set_velocity(handle, (v * math.cos(theta), v * math.sin(theta)))
            _set_angular_velocity(handle, 0.0)
            anchor = 0.0
        else:
            radius = v / omega
            _set_position(handle, (x - radius * math.sin(theta), y + radius * math.cos(theta)))
            _set_angle(handle, theta)
            _set_velocity(handle, (0.0, 0.0))
            _set_angular_velocity(handle, omega)
            anchor = -radius
        self._set_anchor(anchor)

    def set_control_motion(self, motion: list[float], anchor_y: float) -> None:
        """Set the control body to ``motion`` (``(x, y, angle, vx, vy, ω)``) and the drive anchor, as :meth:`apply_command` does.

        For many robots at once (:func:`arc_motion` computes the rows; :mod:`teamgym.sim.world_group`).
        """
        handle = self.control._body
        _set_position(handle, (motion[0], motion[1]))
        _set_angle(handle, motion[2])
        _set_velocity(handle, (motion[3], motion[4]))
        _set_angular_velocity(handle, motion[5])
        self._set_anchor(anchor_y)

    def _set_anchor(self, anchor_y: float) -> None:
        """Put the drive's anchor on the control body at ``(0, anchor_y)`` (each wheel's: offset by the wheel point)."""
        if self.pivot is not None:
            set_pivot_anchor_a(self.pivot, (0.0, anchor_y))
        else:  # each wheel's contact point, in the control body's frame
            for drive, (wx, wy) in zip(self.drives, self.wheel_points):
                set_pivot_anchor_a(drive, (0.0 + wx, anchor_y + wy))

    def disable(self) -> None:
        """Break down: stop the motors for good; the robot stays in the world as an obstacle."""
        self.enabled = False
        self.command = (0.0, 0.0)

    def brake(self, factor: float) -> None:
        """Hold the robot to the ground with ``factor`` times the motors' force and torque limits (locked wheels)."""
        if self.pivot is not None:
            self.pivot.max_force = factor * self.spec.max_motor_force
            self.gear.max_force = factor * self.spec.max_motor_torque
        for drive in self.drives:
            drive.max_force = factor * self.spec.max_motor_force / 2

    # -- bookkeeping around a control step ------------------------------------------
    def begin_step(self, state: list[float] | None = None) -> None:
        """Start a control step: remember the pose and start the command in effect.

        ``state`` is the body's ``(x, y, angle, vx, vy, ω)`` if the caller has read it
        already. With an ``actuation_delay`` the previous command stays in effect first;
        the world switches to the new one after the delay.
        """
        if state is None:
            x, y = self.body.position
            state = [x, y, self.body.angle]
        self._start_pose = (state[0], state[1], state[2])
        delayed = self.actuation_delay > 0.0
        self.apply_command(self.applied_command if delayed else self.command, state)

    def end_step(self, dt: float, start: list[float], end: list[float]) -> None:
        """Update encoders and odometer from the body states at the start and end of a step."""
        x0, y0, a0 = start[0], start[1], start[2]
        x1, y1, a1 = end[0], end[1], end[2]
        dx, dy = x1 - x0, y1 - y0
        mid = 0.5 * (a0 + a1)
        ds = dx * math.cos(mid) + dy * math.sin(mid)
        da = a1 - a0
        half_base = 0.5 * self.spec.wheel_base
        r = self.spec.wheel_radius
        v, omega = self.command
        if 0.0 < self.actuation_delay < dt:
            share = self.actuation_delay / dt
            v = share * self.applied_command[0] + (1 - share) * v
            omega = share * self.applied_command[1] + (1 - share) * omega
        self.applied_command = self.command
        before = self._encoder_values
        # Plain floats: the EncoderReading is built only when someone reads ``encoders``.
        self._encoder_values = encoder_values(v, omega, ds, da, half_base, r, dt, before[4], before[5])
        self.odometer += math.hypot(dx, dy)

    @property
    def encoder_row(self) -> tuple[float, ...]:
        """The six values of :attr:`encoders` as a plain tuple, in its field order (no reading object built)."""
        return self._encoder_values

    @property
    def encoder_totals(self) -> tuple[float, float]:
        """The encoders' total wheel turns ``(left, right)`` (rad) so far."""
        return self._encoder_values[4], self._encoder_values[5]

    def finish_step(self, start_pose: tuple[float, float, float], encoder_values: tuple, distance: float) -> None:
        """:meth:`begin_step` and :meth:`end_step` computed elsewhere for many robots at once (:mod:`teamgym.sim.world_group`).

        ``start_pose``: the pose the step began at; ``encoder_values``: the six readings of
        :class:`EncoderReading`; ``distance``: how far the body moved (added to the odometer).
        """
        self._start_pose = start_pose
        self.applied_command = self.command
        self._encoder_values = encoder_values
        self.odometer += distance

    @property
    def encoders(self) -> EncoderReading:
        """The wheel encoders' reading of the last control step (see :class:`EncoderReading`)."""
        return EncoderReading(*self._encoder_values)

    @encoders.setter
    def encoders(self, reading: EncoderReading) -> None:
        self._encoder_values = (
            reading.commanded_left,
            reading.commanded_right,
            reading.actual_left,
            reading.actual_right,
            reading.total_left,
            reading.total_right,
        )

    # -- world hooks ------------------------------------------------------------------------
    def before_step(self, world: World, state: list[float]) -> float | None:
        """:meth:`begin_step`; asks to switch commands after ``actuation_delay`` if it changed."""
        self.begin_step(state)
        delay = self.actuation_delay
        if 0.0 < delay < world.dt and self.applied_command != self.command:
            return delay
        return None

    def mid_step(self) -> None:
        """The actuation delay is over: start the new command."""
        self.apply_command(self.command)

    def after_step(self, world: World, start: list[float], end: list[float]) -> None:
        self.end_step(world.dt, start, end)

    @classmethod
    def step_group(cls, entities: list[Entity], world: World) -> StepGroup:
        """:class:`RobotSteps` for robots whose class keeps these step hooks (else the entity-by-entity default)."""
        own = all(getattr(cls, name) is getattr(DiffDriveRobot, name) for name in _STEP_HOOKS)
        return RobotSteps(entities, world) if own else super().step_group(entities, world)

    def draw(self, canvas: Canvas) -> None:
        index = canvas.take_index("robot")
        x, y, theta = self.pose
        r = self.spec.radius * canvas.scale
        colour = robot_colour(index) if self.enabled else (120, 120, 120)
        cx, cy = canvas.disc((x, y), r, colour, (0, 0, 0))
        canvas.pen.line([(cx, cy), (cx + r * math.cos(theta), cy - r * math.sin(theta))], fill=(255, 255, 255), width=2)

    # -- state ----------------------------------------------------------------------
    @property
    def pose(self) -> tuple[float, float, float]:
        """``(x, y, θ)`` with θ wrapped to ``(-π, π]``."""
        x, y = self.body.position
        return x, y, wrap_angle(self.body.angle)

    @property
    def velocity(self) -> tuple[float, float]:
        """Actual ``(v, ω)``: speed along the heading and angular speed."""
        vx, vy = self.body.velocity
        theta = self.body.angle
        return vx * math.cos(theta) + vy * math.sin(theta), self.body.angular_velocity

    def teleport(self, position: tuple[float, float], angle: float | None = None) -> None:
        """Place the robot (for resets and scripted events), at rest."""
        self.body.position = position
        if angle is not None:
            self.body.angle = angle
        self.body.velocity = (0.0, 0.0)
        self.body.angular_velocity = 0.0
        place_feet(self.body, self.wheels, self.wheel_points)
        if self.space is not None:
            self.space.reindex_shapes_for_body(self.body)


_STEP_HOOKS = ("before_step", "begin_step", "apply_command", "_set_anchor", "after_step", "end_step")


class RobotSteps(StepGroup):
    """The step hooks of a run of robots in one pass: :meth:`DiffDriveRobot.before_step` and ``after_step``, same numbers.

    A run of at least :data:`BULK_ROBOTS` robots with centre ground contact, in a world whose
    body buffer can be written (:meth:`~teamgym.sim.world.World.body_buffer`), computes
    every control body's arc motion in one numpy pass (sines and cosines from ``math``, as
    :meth:`DiffDriveRobot.apply_command`; the same operations in the same order, so the same
    bits) and leaves them in the buffer, which the world writes in one ``pymunk.batch`` call;
    the pivot anchors are set robot by robot. Other runs call ``apply_command`` robot by robot.
    """

    def __init__(self, robots: list[DiffDriveRobot], world: World) -> None:
        super().__init__(robots)
        centre = all(robot.pivot is not None for robot in robots)
        self.rows = world.body_rows([robot.control for robot in robots]) if centre and len(robots) >= BULK_ROBOTS else None
        self.direct = self.rows is None
        self._pivots = [robot.pivot for robot in robots] if centre else []

    def before(self, world: World, rows: list[list[float]], block: np.ndarray) -> list[tuple[float, Entity]]:
        dt = world.dt
        switches: list[tuple[float, Entity]] = []
        bulk = self.rows is not None
        commands = []
        for robot, row in zip(self.entities, rows):
            robot._start_pose = (row[0], row[1], row[2])
            delay, command = robot.actuation_delay, robot.command
            started = robot.applied_command if delay > 0.0 else command
            if bulk:
                commands.append(started)
            else:
                robot.apply_command(started, row)
            if 0.0 < delay < dt and robot.applied_command != command:
                switches.append((delay, robot))
        if bulk:
            self._drive(world, block, np.array(commands, dtype=float).reshape(-1, 2))
        return switches

    def _drive(self, world: World, block: np.ndarray, commands: np.ndarray) -> None:
        """:meth:`DiffDriveRobot.apply_command` of every robot, into the world's body buffer."""
        motion, anchors = arc_motion(commands, block)
        world.body_buffer()[self.rows] = motion
        for pivot, anchor in zip(self._pivots, anchors.tolist()):
            set_pivot_anchor_a(pivot, (0.0, anchor))

    def after(self, world: World, starts: list[list[float]], ends: list[list[float]]) -> None:
        dt = world.dt
        for robot, start, end in zip(self.entities, starts, ends):
            robot.end_step(dt, start, end)


def encoder_values(
    v: FloatOrArray,
    omega: FloatOrArray,
    ds: FloatOrArray,
    da: FloatOrArray,
    half_base: FloatOrArray,
    r: FloatOrArray,
    dt: float,
    total_left: FloatOrArray,
    total_right: FloatOrArray,
) -> tuple[FloatOrArray, ...]:
    """The six :class:`EncoderReading` values of one control step, for floats or arrays over robots alike.

    ``(v, ω)``: the command in effect; ``ds``, ``da``: how far the body moved along its mid-step
    heading and turned; ``half_base``, ``r``: half the wheel base and the wheel radius;
    ``total_left/right``: the encoders' totals before the step. Commanded wheel turns are
    ``(v ∓ (b/2)·ω)·Δt / r``, actual ones ``(ds ∓ (b/2)·da) / r``. One formula for
    :meth:`DiffDriveRobot.end_step` (floats) and a batch's robots (numpy arrays, the same
    operations in the same order, so the same bits).
    """
    actual_left, actual_right = (ds - half_base * da) / r, (ds + half_base * da) / r
    return (
        (v - half_base * omega) * dt / r,
        (v + half_base * omega) * dt / r,
        actual_left,
        actual_right,
        total_left + actual_left,
        total_right + actual_right,
    )


def arc_motion(commands: np.ndarray, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`DiffDriveRobot.apply_command` of many robots: their control bodies' rows and pivot anchors.

    ``commands`` ``(R, 2)`` are ``(v, ω)``, ``states`` ``(R, >=3)`` the robots' ``(x, y, θ, ...)``.
    Returns the control bodies' ``(x, y, angle, vx, vy, ω)`` rows and each pivot's anchor ``y``;
    sines and cosines from ``math`` and the same operations in the same order as
    ``apply_command``, so the same bits.
    """
    v, omega = commands[:, 0], commands[:, 1]
    x, y, theta = states[:, 0], states[:, 1], states[:, 2]
    angles = theta.tolist()
    cos, sin = np.array(list(map(math.cos, angles))), np.array(list(map(math.sin, angles)))
    straight = np.abs(omega) < 1e-9
    radius = v / np.where(straight, 1.0, omega)
    motion = np.empty((len(v), 6))
    motion[:, 0] = np.where(straight, x, x - radius * sin)
    motion[:, 1] = np.where(straight, y, y + radius * cos)
    motion[:, 2] = theta
    motion[:, 3] = np.where(straight, v * cos, 0.0)
    motion[:, 4] = np.where(straight, v * sin, 0.0)
    motion[:, 5] = np.where(straight, 0.0, omega)
    return motion, np.where(straight, 0.0, -radius)


def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """Wrap an angle (or array of angles) to ``(-π, π]``."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)
