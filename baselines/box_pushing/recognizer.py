"""Per-robot situation recognizer of paper 004 (section 2.4) and the sensed states of section 3.

Each robot recognizes its own situation from its own sensors; nothing is communicated.

* **M** (another robot exists) becomes true when the proximity readings change (by more than
  ``change_threshold`` plus ``change_relative`` times the distance, a margin above the
  sensors' noise on noisy robots, BoxPushing-v1) while the robot stands still, its wheels not having turned during
  the step: only robots move (AS-1). **¬M** when no such change was seen for ``tm`` s.
  The paper does not say when a robot stops to check; ours stops for a *look* of
  1..``look_cycles`` steps (uniform, from the policy's seeded stream) whenever something
  comes into sensor range ahead or touches it ahead (and, with ``look_on_stall``, when it
  stalls). Random durations break the symmetry of two robots that notice each other at the
  same moment: one resumes first and the other sees it move.
* **T** (no heavy box observed) becomes true when the robot pushes an object that is not a
  recognized robot, its central front rays under the object threshold, with its wheels
  turning (slip < 0.2; AS-2: pushing something immovable, the wheels stop) for
  ``push_cycles`` steps in a row. **¬T** when it collides with immovable objects (stalls,
  see no-rotation, with an object ahead) more than ``tt`` times without such a push between.
* Situations: S1 = ¬M ∧ T, S2 = M ∧ T, S3 = M ∧ ¬T, S4 = ¬M ∧ ¬T. Initially ¬M ∧ T (nothing
  observed yet: S1).

Sensed states (sections 3.1, 3.4), recomputed every step, with the sensor groups of Fig. 3
(forward 1–4, left 0, right 5, back 6–7): ``X-object`` (a reading under the 20 mm object
threshold in group X), ``X-light`` (the group holds the brightest light sensor), ``no-light``
(all light readings within 10 % of each other), ``no-rotation`` (the motors were commanded
to drive but the encoders showed more than ``stall_slip`` slip for ``stall_cycles`` steps in
a row), ``X-robot`` (a robot recognized by the M check is sensed in group X, within sensor
range) and ``X-robot-leaving`` (a robot sensed in X stopped being sensed less than
``leaving_time`` s ago and none is sensed there now; this includes a reading in X that
moved out of range while the robot stood still: a robot seen leaving by the M check). A
recognized robot is a *mark*: a bearing in the robot's frame, turned with the robot's own
rotation (odometry) and moved to the nearest ray within ``mark_width`` that still sees
something; when none does, the robot has left. A mark that shows no change for ``mark_patience`` still steps is forgotten (that
robot stopped; nothing tells it from a box any more), so two robots that stop facing each
other (B-14) do not wait for ever.

``robot_facts="touching"`` (the literal reading, ``sbs-literal``) reads "sensed" in
``X-robot`` as in ``X-object`` (section 3.1, within 20 mm): ``X-robot`` holds only where a
mark lies in group X *and* ``X-object`` holds there, and ``X-robot-leaving`` holds for
``leaving_time`` s after ``X-robot`` stopped holding (the robot "becomes not to be sensed").
The M check, the marks and M are the same in both readings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from teamgym.control.primitives import BACK_RAYS, FORWARD_RAYS, LEFT_RAYS, RIGHT_RAYS
from teamgym.sim.robot import wrap_angle

GROUPS: dict[str, tuple[int, ...]] = {"forward": FORWARD_RAYS, "left": LEFT_RAYS, "right": RIGHT_RAYS, "back": BACK_RAYS}
SITUATIONS = {(False, True): "S1", (True, True): "S2", (True, False): "S3", (False, False): "S4"}


def group_of_bearing(bearing: float) -> str:
    """Sensor group of a bearing (rad, CCW from the heading): forward within ±67.5°, back beyond ±135°."""
    b = abs(float(wrap_angle(bearing)))
    if b <= math.radians(67.5):
        return "forward"
    if b >= math.radians(135.0):
        return "back"
    return "left" if wrap_angle(bearing) > 0 else "right"


@dataclass(frozen=True)
class RecognizerParams:
    """Thresholds and time constants of the recognizer (SI units; ``tt`` is a count).

    ``robot_facts``: ``"marks"`` (X-robot wherever a mark is, within sensor range) or
    ``"touching"`` (X-robot only where X-object holds too; the literal reading).
    """

    dt: float = 0.1
    object_threshold: float = 0.02
    sensor_range: float = 0.1
    tm: float = 60.0
    tt: int = 10
    change_threshold: float = 0.004
    change_relative: float = 0.0
    stall_slip: float = 0.8
    stall_cycles: int = 3
    push_cycles: int = 10
    look_cycles: int = 3
    look_on_stall: bool = False
    look_on_sighting: bool = True
    leaving_time: float = 3.0
    mark_width: float = math.radians(60.0)
    mark_patience: int = 20
    robot_facts: str = "marks"
    wheel_radius: float = 0.008
    wheel_base: float = 0.053
    ray_angles: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.robot_facts not in ("marks", "touching"):
            raise ValueError(f"robot_facts must be 'marks' or 'touching', got {self.robot_facts!r}")


@dataclass
class Transition:
    """A change of the recognized situation at ``time`` (s)."""

    time: float
    before: str
    after: str


@dataclass
class SituationRecognizer:
    """Recognizes M/T and the sensed states of one robot from its observations."""

    params: RecognizerParams
    rng: np.random.Generator | None = None
    m: bool = False
    t: bool = True
    time: float = 0.0
    last_m_time: float = -math.inf
    immovable_collisions: int = 0
    transitions: list[Transition] = field(default_factory=list)

    def __post_init__(self) -> None:
        #: Recognized robots: [bearing in the robot's frame (rad), still steps without a change there].
        self.marks: list[list] = []
        self._leaving: dict[str, float] = {}
        self._touching: set[str] = set()  # robot_facts="touching": groups with X-robot last step
        self._touch_left: dict[str, float] = {}  # ... and when X-robot last stopped holding there
        self._previous: np.ndarray | None = None
        self._stall = 0
        self._push = 0
        self._look = 0
        self._ahead = math.inf
        self._latched_stall = False
        self._angles = np.asarray(self.params.ray_angles, dtype=float)
        self.facts: frozenset[str] = frozenset()

    @property
    def situation(self) -> str:
        return SITUATIONS[(self.m, self.t)]

    def update(
        self, proximity: np.ndarray, light: np.ndarray, encoders: np.ndarray, robots: list[float] | None = None
    ) -> frozenset[str]:
        """Process one step's readings; returns the set of sensed states that hold now.

        ``robots`` (diagnostic, :mod:`baselines.box_pushing.oracle`): bearings of the robots a perfect M
        check would recognize now; given, they replace the marks and the M check.
        """
        p = self.params
        before = self.situation
        self.time += p.dt
        proximity = np.asarray(proximity, dtype=float)
        commanded = float(encoders[0] + encoders[1])
        actual_left, actual_right = float(encoders[2]), float(encoders[3])
        turned = (actual_right - actual_left) * p.wheel_radius / p.wheel_base
        still = abs(actual_left) + abs(actual_right) < 0.02
        lost = abs(encoders[0] - actual_left) + abs(encoders[1] - actual_right)
        slip = lost / (abs(encoders[0]) + abs(encoders[1])) if commanded > 1e-9 else 0.0
        self._stall = self._stall + 1 if commanded > 1e-9 and slip > p.stall_slip else 0
        objects = {g: bool(min(proximity[i] for i in rays) < p.object_threshold) for g, rays in GROUPS.items()}
        ahead = min(proximity[i] for i in FORWARD_RAYS)
        self._update_look(objects["forward"], ahead < p.sensor_range and self._ahead >= p.sensor_range)
        self._ahead = ahead

        if robots is not None:
            self._take_true_robots(robots)
        else:
            self._track_marks(proximity, turned)
            if still and self._previous is not None:
                self._check_m(proximity)
        if self.m and self.time - self.last_m_time > p.tm:
            self.m = False
        self._check_t(proximity, commanded, slip, objects["forward"])
        self._previous = proximity.copy()

        facts = {f"{g}-object" for g, hit in objects.items() if hit}
        facts |= self._light_facts(np.asarray(light, dtype=float))
        if self._stall >= p.stall_cycles or (self._latched_stall and not self._look):
            facts.add("no-rotation")
            self._latched_stall = bool(self._look)
        robot_groups = {group_of_bearing(b) for b, _ in self.marks}
        leaving = self._leaving
        if p.robot_facts == "touching":
            robot_groups = {g for g in robot_groups if objects[g]}
            self._touch_left.update(dict.fromkeys(self._touching - robot_groups, self.time))
            self._touching, leaving = robot_groups, self._touch_left
        facts |= {f"{g}-robot" for g in robot_groups}
        facts |= {
            f"{g}-robot-leaving" for g, when in leaving.items() if g not in robot_groups and self.time - when <= p.leaving_time
        }
        self.facts = frozenset(facts)
        if self.situation != before:
            self.transitions.append(Transition(self.time, before, self.situation))
        return self.facts

    @property
    def looking(self) -> bool:
        """Whether the robot should stand still this step to look for moving robots (the M check)."""
        return self._look > 0

    def _update_look(self, forward_object: bool, sighted: bool) -> None:
        """Start a look when something comes into range ahead, touches ahead, or the robot stalls.

        A look lasts 1..``look_cycles`` steps, drawn uniformly: two robots that notice each
        other in the same step do not resume in the same step, so one sees the other move.
        """
        p = self.params
        if self._look:
            self._look -= 1
            return
        stalled = self._stall == p.stall_cycles and p.look_on_stall
        touched = forward_object and "forward-object" not in self.facts
        if p.look_cycles and (stalled or touched or (sighted and p.look_on_sighting)):
            self._look = int(self.rng.integers(1, p.look_cycles + 1)) if self.rng is not None else p.look_cycles
            self._latched_stall = stalled

    def _robot_ahead(self) -> bool:
        return any(group_of_bearing(b) == "forward" for b, _ in self.marks)

    # -- M ---------------------------------------------------------------------------------
    def _check_m(self, proximity: np.ndarray) -> None:
        """Standing still, a reading that changed means a moving object: another robot (AS-1).

        A reading that changed by moving *out* of range, where no mark was, is a robot seen
        leaving while the robot stood still: "another robot which was sensed forward/back
        becomes not to be sensed" (section 3.4), so ``X-robot-leaving`` starts there too.

        Marks that show no change for ``mark_patience`` still steps stand for robots that
        stopped moving; they are forgotten (the object is still there, but nothing tells it
        from a box any more), which also keeps two robots that stop facing each other from
        waiting for ever.
        """
        p = self.params
        previous = self._previous
        nearest = np.minimum(proximity, previous)
        margin = p.change_threshold + p.change_relative * nearest if p.change_relative else p.change_threshold
        changed = (np.abs(proximity - previous) > margin) & (nearest < p.sensor_range)
        seen = set()
        for ray in np.flatnonzero(changed).tolist():
            self.m = True
            self.last_m_time = self.time
            angle = float(self._angles[ray])
            near = [k for k, mark in enumerate(self.marks) if abs(wrap_angle(angle - mark[0])) <= p.mark_width / 2]
            if near:
                seen.update(near)
            elif proximity[ray] < p.sensor_range:
                self.marks.append([angle, 0])
                seen.add(len(self.marks) - 1)
            else:
                # A moving object (a robot, AS-1) was sensed here and now is not: it left.
                self._leaving[group_of_bearing(angle)] = self.time
        for k, mark in enumerate(self.marks):
            mark[1] = 0 if k in seen else mark[1] + 1
        self.marks = [mark for mark in self.marks if mark[1] < p.mark_patience]

    def _take_true_robots(self, bearings: list[float]) -> None:
        """Marks from ground truth: M is refreshed by every recognized robot; a group that lost its robots starts leaving."""
        now = {group_of_bearing(b) for b in bearings}
        for bearing, _ in self.marks:
            if group_of_bearing(bearing) not in now:
                self._leaving[group_of_bearing(bearing)] = self.time
        self.marks = [[b, 0] for b in bearings]
        if bearings:
            self.m = True
            self.last_m_time = self.time

    def _track_marks(self, proximity: np.ndarray, turned: float) -> None:
        """Turn marks with the robot, move each to the nearest ray still seeing something, drop the rest."""
        p = self.params
        kept: list[list] = []
        for bearing, quiet in self.marks:
            bearing = float(wrap_angle(bearing - turned))
            near = [
                i
                for i in range(len(self._angles))
                if proximity[i] < p.sensor_range and abs(wrap_angle(self._angles[i] - bearing)) <= p.mark_width
            ]
            if not near:
                self._leaving[group_of_bearing(bearing)] = self.time
                continue
            nearest = min(near, key=lambda i: abs(wrap_angle(self._angles[i] - bearing)))
            bearing = float(self._angles[nearest])
            if all(abs(wrap_angle(bearing - other[0])) > p.mark_width / 2 for other in kept):
                kept.append([bearing, quiet])
        self.marks = kept

    # -- T ---------------------------------------------------------------------------------
    def _check_t(self, proximity: np.ndarray, commanded: float, slip: float, forward_object: bool) -> None:
        p = self.params
        centre = min(proximity[2], proximity[3]) < p.object_threshold
        pushing = commanded > 1e-9 and slip < 0.2 and centre and not self._robot_ahead()
        self._push = self._push + 1 if pushing else 0
        if self._push >= p.push_cycles:
            self.t = True
            self.immovable_collisions = 0
        if self._stall == p.stall_cycles and forward_object:
            self.immovable_collisions += 1
            if self.immovable_collisions > p.tt:
                self.t = False

    # -- light -----------------------------------------------------------------------------
    @staticmethod
    def _light_facts(light: np.ndarray) -> set[str]:
        top = float(light.max())
        if top <= 1e-12 or float(light.max() - light.min()) < 0.1 * top:
            return {"no-light"}
        brightest = int(np.argmax(light))
        return {f"{g}-light" for g, rays in GROUPS.items() if brightest in rays}
