"""``cooperative-push``: a scripted team that pushes boxes to the lamp together without talking.

Not the paper's method (that is ``sbs``): a strong decentralised reference for BoxPushing
(issue 14, part 3). Every robot runs its own :class:`PushController` on its own readings —
proximity rays, light intensities and wheel encoders — and drives its wheels (``action_type=
"wheels"``); nothing is communicated and nothing is read from the simulator. Design
(``docs/box_pushing.md``, *cooperative-push*, with the state diagram):

* **The lamp is a shared compass.** Every robot pushes only towards the lamp and only from
  the side of an object facing away from it, so robots meet on the same face of a box
  without recognising each other, and a robot arriving behind a pushing robot pushes it
  (a line: the motors' forces add).
* **Go around to the far side.** An object met anywhere else is circled, keeping it on the
  lamp's side, until it lies between the robot and the lamp.
* **Stall and wait for help.** A robot whose wheels stall against an object it has not moved
  yet keeps pushing, its aim swept left and right after ``block_time``, for
  ``shove_unmoved`` s: a heavy box needs a second pusher, who arrives in that time. Then it
  shoves the object aside once and leaves. Near the goal wall (bright light) a stall means
  the goal: the robot leaves.
* **Hold the push's direction** (``hold_heading``): by odometry, at an aim within
  ``aim_spread`` of the lamp, so boxes reach the goal wall beside each other rather than
  all at the lamp's point.
* **Blocked after moving a box: push past.** A box that moved and then stopped (against a
  delivered box, a robot) is pushed with its aim swept aside of the lamp line and, after
  ``shove_moved`` s, shoved square to the lamp line, then pushed to the lamp again.
* **Leave, and do not come straight back**: after leaving, objects are avoided for
  ``cooldown`` (no lamp-ward push, no circling).

The lamp's bearing is fitted to the eight light readings (:func:`lamp_bearing`), robust to
the per-sensor gains of BoxPushing-v1; the intensity's scale only separates "at the goal
wall" from "anywhere else". Every robot has its own random stream (``reset(seed)``).
"""

from __future__ import annotations

import functools
import math
from collections import Counter
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from baselines.policy import Policy
from teamgym.envs.actions import WheelSpeedAction

#: Controller states (the state diagram in docs/box_pushing.md).
EXPLORE, CIRCLE, FACE, PUSH, WAIT, SIDESTEP, BACKOFF, TURN = (
    "explore",
    "circle",
    "face",
    "push",
    "wait",
    "sidestep",
    "backoff",
    "turn",
)
STATES = (EXPLORE, CIRCLE, FACE, PUSH, WAIT, SIDESTEP, BACKOFF, TURN)


@dataclass(frozen=True)
class PushParams:
    """Speeds (m/s), rates (rad/s), angles (rad), distances (m), times (s) and light levels of the controller."""

    cruise_speed: float = 0.3
    push_speed: float = 0.08
    circle_speed: float = 0.1
    turn_rate: float = 4.0
    engage_distance: float = 0.035
    align_tolerance: float = math.radians(40.0)
    circle_exit: float = math.radians(25.0)
    circle_distance: float = 0.02
    circle_time: float = 12.0
    wall_time: float = 2.5
    wall_turn: float = math.radians(20.0)
    heading_gain: float = 5.0
    max_heading: float = math.radians(60.0)
    line_gain: float = 0.3
    goal_cooldown: float = 1.0
    lost_time: float = 0.8
    stall_slip: float = 0.7
    stall_steps: int = 3
    goal_intensity: float = 25.0
    shove_at_goal: bool = True
    aim_spread: float = math.radians(20.0)
    hold_heading: bool = True
    hold_limit: float = math.radians(35.0)
    moved_distance: float = 0.03
    wait_heading: str = "line"
    contact_distance: float = 0.012
    face_check_time: float = 1.0
    face_tolerance: float = math.radians(50.0)
    block_time: float = 3.0
    shove_moved: float = 6.0
    shove_unmoved: float = 30.0
    shove_distance: float = 0.08
    shove_backoff: float = 0.03
    sweep_unmoved: bool = True
    sidestep_angle: float = math.radians(25.0)
    sidestep_period: float = 3.0
    backoff_distance: float = 0.04
    cooldown: float = 8.0
    wander_turn: float = 0.2
    wander_period: float = 2.0


@functools.lru_cache(maxsize=8)
def _lamp_models(angles: tuple[float, ...], grid: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate bearings, the cosine lamp model per candidate and sensor, and its squared norms (built once)."""
    phis = np.linspace(-math.pi, math.pi, grid, endpoint=False)
    model = np.maximum(np.cos(phis[:, None] - np.asarray(angles)[None, :]), 0.0)
    return phis, model, np.maximum((model * model).sum(axis=1), 1e-12)


def lamp_bearing(light: np.ndarray, angles: np.ndarray, grid: int = 180) -> tuple[float, float]:
    """Bearing (rad, CCW from the heading) and amplitude of the lamp from the light readings.

    Least squares over the lamp model of :class:`~teamgym.sim.sensors.LightSensor`,
    ``L_i = A · max(0, cos(φ − α_i))``: for each candidate ``φ`` on a grid the best ``A`` is a
    projection; the ``φ`` with the smallest residual wins (refined by a parabola through its
    neighbours). ``A`` is ``I₀ / d²`` times the sensors' gains.
    """
    phis, model, norm = _lamp_models(tuple(np.asarray(angles, dtype=float).tolist()), grid)
    light = np.asarray(light, dtype=float)
    dot = model @ light
    score = dot * dot / norm  # residual = |L|² − score
    k = int(np.argmax(score))
    a, b, c = score[k - 1], score[k], score[(k + 1) % grid]
    denominator = a - 2 * b + c
    shift = 0.5 * (a - c) / denominator if denominator < 0 else 0.0
    phi = phis[k] + float(np.clip(shift, -0.5, 0.5)) * (2 * math.pi / grid)
    return float(math.remainder(phi, 2 * math.pi)), float(max(dot[k], 0.0) / norm[k])


class PushController:
    """One robot's state machine (see the module docstring); :meth:`step` maps readings to wheel speeds."""

    def __init__(
        self,
        params: PushParams,
        angles: np.ndarray,
        wheel_base: float,
        wheel_radius: float,
        dt: float,
        sensor_range: float,
        max_wheel_speed: float,
        rng: np.random.Generator,
    ) -> None:
        self.p = params
        self.angles = np.asarray(angles, dtype=float)
        self.half_base = wheel_base / 2
        self.wheel_radius = wheel_radius
        self.dt = dt
        self.reach = sensor_range
        self.max_wheel = max_wheel_speed
        self.rng = rng
        self.state = EXPLORE
        self.timer = 0.0  # time in the current state
        self.side = 1.0  # circling: +1 object on the left, -1 on the right; sidestep: aim side
        self.wander = 0.0
        self.wander_timer = 0.0
        self.cooldown = 0.0
        self.moved = False  # the object being pushed has moved (``moved_distance``) in this engagement
        self.pushed = 0.0  # distance driven in contact in this engagement (m)
        self.stalled = 0
        self.lost = 0.0
        self.stall_time = 0.0
        self.turn_left = 0.0  # TURN: angle still to turn (rad)
        self.backoff_left = 0.0
        self.after_turn = EXPLORE
        self.bias = 0.0  # aim of this push, relative to the compass
        self.push_heading: float | None = None  # direction of this push by odometry (``hold_heading``)
        self.offset = 0.0  # direction pushed, relative to the lamp's: ±90° during a shove
        self.headings: list[float] = []  # CIRCLE: heading (by odometry) per step, to tell a wall
        self.heading = 0.0
        self.steps: Counter[str] = Counter()

    # -- helpers ----------------------------------------------------------------------------
    def _to(self, state: str) -> None:
        self.state, self.timer = state, 0.0
        self.headings = []

    def _wheels(self, v: float, omega: float) -> tuple[float, float]:
        left, right = v - self.half_base * omega, v + self.half_base * omega
        peak = max(abs(left), abs(right), 1e-12)
        scale = min(1.0, self.max_wheel / peak)
        return left * scale, right * scale

    def _turn_by(self, angle: float, then: str) -> None:
        self.turn_left, self.after_turn = float(angle), then
        self._to(TURN)

    def _leave(self, turn: float | None = None, cooldown: float | None = None, shove: float = 0.0) -> None:
        """Back off, turn away (about 180° ± 45°) and explore; objects are avoided for ``cooldown`` s.

        ``shove`` is the compass offset of the next engagement (0: the lamp).
        """
        self.offset = shove
        self.backoff_left = self.p.backoff_distance
        if turn is None:
            turn = math.copysign(math.pi * 0.75 + float(self.rng.uniform(0, math.pi / 2)), float(self.rng.uniform(-1, 1)))
        self.turn_left = turn
        self.cooldown = self.p.cooldown if cooldown is None else cooldown
        self._to(BACKOFF)

    def _face_normal(self, prox: np.ndarray) -> float | None:
        """Bearing of the normal of the flat surface the front rays see (towards it), or ``None``.

        A line fitted to the hit points of rays 1–4; needs hits spread over 1.5 cm across.
        """
        hits = [i for i in (1, 2, 3, 4) if prox[i] < 0.05]
        if len(hits) < 2:
            return None
        r = self.half_base + 0.001
        points = np.array([((r + prox[i]) * math.cos(self.angles[i]), (r + prox[i]) * math.sin(self.angles[i])) for i in hits])
        if np.ptp(points[:, 1]) < 0.015:
            return None
        centred = points - points.mean(axis=0)
        _, _, vt = np.linalg.svd(centred)
        nx, ny = vt[1]
        if nx < 0:
            nx, ny = -nx, -ny
        return math.atan2(ny, nx)

    def _object_bearing(self, prox: np.ndarray) -> float | None:
        """Bearing of the centre of what the front rays see (mean of their hit points), or ``None``."""
        hits = [i for i in (1, 2, 3, 4) if prox[i] < 0.06]
        if not hits:
            return None
        r = self.half_base + 0.001
        x = sum((r + prox[i]) * math.cos(self.angles[i]) for i in hits)
        y = sum((r + prox[i]) * math.sin(self.angles[i]) for i in hits)
        return math.atan2(y, x)

    # -- the controller ---------------------------------------------------------------------
    def step(self, prox: np.ndarray, light: np.ndarray, enc: np.ndarray) -> tuple[float, float]:
        """Wheel rim speeds (m/s) for this cycle from the last readings."""
        p, dt = self.p, self.dt
        self.timer += dt
        self.cooldown = max(0.0, self.cooldown - dt)
        bearing, amplitude = lamp_bearing(light, self.angles)
        bearing = math.remainder(bearing - self.offset, 2 * math.pi)  # the compass: the lamp, or aside of it in a shove
        commanded = abs(enc[0]) + abs(enc[1])
        lost = abs(enc[0] - enc[2]) + abs(enc[1] - enc[3])
        slip = lost / commanded if commanded > 1e-6 else 0.0
        self.stalled = self.stalled + 1 if (commanded > 0.2 and slip > p.stall_slip) else 0
        turned = (enc[3] - enc[2]) * self.wheel_radius / (2 * self.half_base)
        travelled = 0.5 * (enc[2] + enc[3]) * self.wheel_radius
        front = float(min(prox[1], prox[2], prox[3], prox[4]))
        self.heading += turned
        self.steps[self.state] += 1

        if self.state == TURN:
            self.turn_left -= turned
            if (
                abs(self.turn_left) < math.radians(5)
                or self.timer > 3.0
                or math.copysign(1, self.turn_left) != math.copysign(1, self.turn_left + turned)
            ):
                self._to(self.after_turn)
            else:
                return self._wheels(0.0, math.copysign(min(p.turn_rate, abs(self.turn_left) / dt), self.turn_left))
        if self.state == BACKOFF:
            self.backoff_left += travelled  # travelled < 0 backwards
            if self.backoff_left <= 0 or self.timer > 1.5 or min(prox[6], prox[7]) < 0.01:
                self._turn_by(self.turn_left, EXPLORE)
                return self._wheels(0.0, 0.0)
            return self._wheels(-p.push_speed, 0.0)

        if self.state == EXPLORE:
            return self._explore(prox, bearing, front)
        if self.state == CIRCLE:
            return self._circle(prox, bearing, front)
        if self.state == FACE:
            if abs(bearing) < math.radians(10) or self.timer > 2.0:
                self._start_push()
            else:
                return self._wheels(0.0, float(np.clip(3.0 * bearing, -p.turn_rate, p.turn_rate)))
        if self.state in (PUSH, WAIT, SIDESTEP):
            return self._push(prox, bearing, amplitude, front, travelled)
        return self._wheels(0.0, 0.0)

    def _end_shove(self) -> None:
        """Back to the lamp as the compass; back off a little and engage the object again."""
        self._leave(turn=0.0, cooldown=0.0)
        self.backoff_left = self.p.shove_backoff

    def _start_push(self) -> None:
        self.moved, self.lost, self.stall_time, self.pushed = False, 0.0, 0.0, 0.0
        # Aim a little aside of the lamp, anew for every push: boxes then reach different points
        # of the goal wall instead of queueing on the lamp's line.
        self.bias = float(self.rng.uniform(-self.p.aim_spread, self.p.aim_spread))
        self.push_heading = None
        self._to(PUSH)

    def _explore(self, prox: np.ndarray, bearing: float, front: float) -> tuple[float, float]:
        p = self.p
        if front < p.engage_distance:
            nearest = min((1, 2, 3, 4), key=lambda i: prox[i])
            towards = float(self.angles[nearest])
            offset = math.remainder(bearing - towards, 2 * math.pi)
            if self.cooldown > 0:
                self._turn_by(-math.copysign(math.pi / 2 + float(self.rng.uniform(0, math.pi / 2)), towards or 1.0), EXPLORE)
            elif abs(offset) < p.align_tolerance:
                self._to(FACE)
            else:
                self.side = 1.0 if offset > 0 else -1.0
                self._to(CIRCLE)
            return self._wheels(0.0, 0.0)
        self.wander_timer -= self.dt
        if self.wander_timer <= 0:
            self.wander = float(self.rng.uniform(-p.wander_turn, p.wander_turn))
            self.wander_timer = p.wander_period * float(self.rng.uniform(0.5, 1.5))
        omega = self.wander
        # keep off things at the sides
        if prox[0] < 0.02:
            omega -= 2.0
        if prox[5] < 0.02:
            omega += 2.0
        return self._wheels(p.cruise_speed, omega)

    def _circle(self, prox: np.ndarray, bearing: float, front: float) -> tuple[float, float]:
        """Follow the object's boundary, keeping it on side ``self.side``, until it lies towards the lamp."""
        p, s = self.p, self.side
        side_ray, diag_ray = (0, 1) if s > 0 else (5, 4)
        side_d, diag_d = float(prox[side_ray]), float(prox[diag_ray])
        towards = s * math.pi / 2
        if side_d < 0.05 and abs(math.remainder(bearing - towards, 2 * math.pi)) < p.circle_exit:
            self._turn_by(towards, FACE)
            return self._wheels(0.0, 0.0)
        self.headings.append(self.heading if side_d < 0.06 else math.nan)
        window = self.headings[-round(p.wall_time / self.dt) :]
        straight = len(window) * self.dt >= p.wall_time and not np.isnan(window).any() and np.ptp(window) < p.wall_turn
        if self.timer > p.circle_time or straight:  # too long, or a long straight side: a wall
            self._leave(turn=-s * (math.pi / 2 + float(self.rng.uniform(0, math.pi / 3))))
            return self._wheels(0.0, 0.0)
        if front < 0.02 or diag_d < 0.012:
            return self._wheels(0.0, -s * p.turn_rate * 0.6)
        if side_d < 0.06:
            omega = s * 8.0 * (side_d - p.circle_distance)
            return self._wheels(p.circle_speed, float(np.clip(omega, -3.0, 3.0)))
        if diag_d < 0.06:
            return self._wheels(p.circle_speed * 0.7, -s * 1.0)
        return self._wheels(p.circle_speed * 0.6, s * 2.5)  # lost it at a corner: arc round

    def _push(self, prox: np.ndarray, bearing: float, amplitude: float, front: float, travelled: float) -> tuple[float, float]:
        p, dt = self.p, self.dt
        if front >= 0.05:
            self.lost += dt
            if self.lost > p.lost_time:
                self._to(EXPLORE)
                return self._wheels(p.cruise_speed, 0.0)
        else:
            self.lost = 0.0
        if abs(bearing) > math.radians(75):  # the lamp is no longer ahead: go round again
            self.side = 1.0 if bearing > 0 else -1.0
            self._to(CIRCLE)
            return self._wheels(0.0, 0.0)
        stalled = self.stalled >= p.stall_steps
        if stalled:
            if self.state == PUSH:
                self.state, self.stall_time = WAIT, 0.0
                self.side = 1.0 if self.rng.uniform() < 0.5 else -1.0
            self.stall_time += dt
            if amplitude > p.goal_intensity:
                if self.moved and self.offset == 0.0 and p.shove_at_goal:
                    # A box that stopped near the goal: delivered, or blocked short of the wall by
                    # a delivered box. Shove it aside once (harmless if it is at the wall).
                    self._leave(turn=0.0, cooldown=0.0, shove=self.side * math.pi / 2)
                    self.backoff_left = p.shove_backoff
                else:  # against the goal wall, or a box at it
                    self._leave(cooldown=p.goal_cooldown)
                return self._wheels(0.0, 0.0)
            normal = self._face_normal(prox)
            if (
                self.offset == 0.0
                and normal is not None
                and self.stall_time > p.face_check_time
                and abs(math.remainder(normal - bearing, 2 * math.pi)) > p.face_tolerance
            ):  # stuck on a face that does not face away from the lamp (a wall near a goal corner, a box's side)
                self._leave(
                    turn=math.copysign(math.pi / 2, math.remainder(normal - bearing, 2 * math.pi)), cooldown=p.goal_cooldown
                )
                return self._wheels(0.0, 0.0)
            if self.state == WAIT and (self.moved or p.sweep_unmoved) and self.stall_time > p.block_time:
                self.state = SIDESTEP  # blocked (or waiting): try past an obstacle, aside of the lamp line
            if self.offset != 0.0:  # a shove ends when the object stops: push it to the lamp again
                self._end_shove()
                return self._wheels(0.0, 0.0)
            if self.stall_time > (p.shove_moved if self.moved else p.shove_unmoved):
                # Blocked: shove the object aside, pushing it square to the lamp line from one side.
                self._leave(turn=0.0, cooldown=0.0, shove=self.side * math.pi / 2)
                self.backoff_left = p.shove_backoff
                return self._wheels(0.0, 0.0)
        elif self.stalled == 0:
            if self.state != PUSH:
                self.state = PUSH  # moving again
            if front < p.contact_distance and travelled > 0:
                self.pushed += travelled
                self.moved = self.moved or self.pushed > p.moved_distance
                if self.offset != 0.0 and self.pushed > p.shove_distance:
                    self._end_shove()
                    return self._wheels(0.0, 0.0)
        aim = self.bias if self.offset == 0.0 else 0.0
        if self.state == SIDESTEP:
            phase = int((self.stall_time - p.block_time) / p.sidestep_period) % 4
            aim += (self.side, 0.0, -self.side, 0.0)[phase] * p.sidestep_angle
        # Head past the box on the far side of the lamp line: the robot slides along the box's face
        # onto the line from the box to the lamp (the box goes where its face is pushed).
        target = math.remainder(bearing - aim, 2 * math.pi)
        if p.hold_heading and self.offset == 0.0:
            # Hold the direction the push started in (odometry): a box pushed straight at an aim
            # beside the lamp reaches the goal wall beside the boxes already there, where
            # re-aiming at the lamp all the way would bring every box to the lamp's point.
            if self.push_heading is None:
                self.push_heading = self.heading + bearing - self.bias
            held = math.remainder(self.push_heading - self.heading - (aim - self.bias), 2 * math.pi)
            target = target + float(np.clip(math.remainder(held - target, 2 * math.pi), -p.hold_limit, p.hold_limit))
        box = self._object_bearing(prox)
        normal = self._face_normal(prox) if (self.state == WAIT and p.wait_heading == "normal") else None
        if normal is not None:  # stalled on an unmoved object: push square to its face, with the full force
            heading = normal
        elif self.state == WAIT and p.wait_heading == "lamp":
            heading = target
        else:
            heading = target if box is None else box + p.line_gain * (box - target)
        heading = float(np.clip(heading, -p.max_heading, p.max_heading))
        # Both wheels keep driving forward: a wheel turning backwards would take its motor's force off the push.
        limit = 0.9 * p.push_speed / self.half_base
        return self._wheels(p.push_speed, float(np.clip(p.heading_gain * heading, -limit, limit)))


class CooperativePush(Policy):
    """Decentralised cooperative pushing with the lamp as a shared compass (see the module docstring).

    Parameters
    ----------
    env:
        A ``BoxPushing-v0`` or ``-v1`` env with ``action_type="wheels"``.
    **params:
        Overrides of :class:`PushParams`.
    """

    name = "cooperative-push"
    env_ids = ("BoxPushing-v0", "BoxPushing-v1")
    observation_fields = ("proximity", "light", "encoders")
    required_config = {"action_type": "wheels"}

    def __init__(self, env, **params: Any) -> None:
        super().__init__(env)
        if not isinstance(getattr(env, "action_type", None), WheelSpeedAction):
            raise TypeError(f"{type(self).__name__} needs BoxPushing-v0 or -v1 with action_type='wheels'")
        known = {f.name for f in fields(PushParams)}
        unknown = sorted(set(params) - known)
        if unknown:
            raise TypeError(f"unknown cooperative-push parameter(s) {unknown}; known: {sorted(known)}")
        self.params = replace(PushParams(), **params)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.seed = seed
        self.controllers: dict[str, PushController] = {}

    def _controller(self, agent: str) -> PushController:
        controller = self.controllers.get(agent)
        if controller is None:
            env = self.env
            index = env.possible_agents.index(agent)
            rng = np.random.default_rng(None if self.seed is None else [self.seed, index])
            spec = env.spec_robot
            controller = PushController(
                self.params,
                env.ring.angles,
                spec.wheel_base,
                spec.wheel_radius,
                env.config.dt,
                env.config.sensor_range,
                spec.max_wheel_speed,
                rng,
            )
            self.controllers[agent] = controller
        return controller

    def act(self, observations, infos=None):
        decode = self.env.decode
        actions = {}
        for agent, obs in observations.items():
            f = decode(obs)
            left, right = self._controller(agent).step(f["proximity"], f["light"], f["encoders"])
            actions[agent] = np.array([left, right], dtype=np.float32)
        return actions

    def state_steps(self) -> Counter[str]:
        """Robot-steps spent in each controller state so far."""
        total: Counter[str] = Counter()
        for controller in self.controllers.values():
            total.update(controller.steps)
        return total
