"""Behaviour-based motion controller of paper 000, section 2.2 (Fig. 3).

Seven behaviours map the proximity ring, the pose and the target to activation levels
a_i ∈ (0, 1) by sigmoid functions; a fixed-priority arbiter picks the behaviour

    k = argmax_i a_i q_i,   i = 1..7                                          (5)

and the winner alone sets the controls from its activation, ``[v, ω] = f_k(a_k)`` (6).
The paper gives neither the sigmoids nor f_k (it refers to [Skrzypczyk 2002]); our choices
(documented in docs/exploration.md and tested in tests/envs/test_behaviour.py):

============== ========================================= ===================================
behaviour      activation a_i                            control f_i(a_i)
============== ========================================= ===================================
avoid left     σ(s (d_avoid − d_L)), d_L = min(d_1, d_0+δ) v = v_max (1 − 0.8 a), ω = −ω_max a
avoid right    σ(s (d_avoid − d_R)), d_R = min(d_4, d_5+δ) v = v_max (1 − 0.8 a), ω = +ω_max a
avoid front    σ(s (d_front − d_F)), d_F = min(d_2, d_3)  v = −0.2 v_max a, ω = ±ω_max a
goal tracking  σ(g (ρ − ρ_tol)), ρ = distance to target   v = v_max a cos²e (e: heading error,
                                                          cos e > 0, at most 1.5 ρ /s),
                                                          ω = sat(K_h e)
stop           1 on a collision or without a target,      v = 0, ω = 0
               else σ(g (ρ_tol − ρ))
stroll         σ(s (d_min − d_avoid)) (nothing near)      v = v_max a, ω = 0
narrow passage σ(s (d_pass − d_L)) σ(s (d_pass − d_R))    v = 0.6 v_max a cos²e,
                                                          ω = sat(K_c (d_0 − d_5) + ½ K_h e)
============== ========================================= ===================================

with σ(z) = 1 / (1 + e^(−z)), ray distances d_k of the Khepera ring (0 left, 1–4 front,
5 right), δ = 2 cm (the side rays see walls alongside, which need no avoiding unless very
near). Avoid front turns towards the freer side and keeps its direction while it stays
active (no dithering in front of a wall). Default priorities q: stop 1.0, avoid front 0.9,
narrow passage 0.85, avoid left/right 0.8, goal tracking 0.6, stroll 0.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

BEHAVIOURS = ("avoid_left", "avoid_right", "avoid_front", "goal_tracking", "stop", "stroll", "narrow_passage")
AVOID_LEFT, AVOID_RIGHT, AVOID_FRONT, GOAL_TRACKING, STOP, STROLL, NARROW_PASSAGE = range(7)
DEFAULT_PRIORITIES = (0.8, 0.8, 0.9, 0.6, 1.0, 0.3, 0.85)


def _wrap(angle: float) -> float:
    """:func:`teamgym.sim.robot.wrap_angle` of one float: the same floored modulo (numpy's and Python's agree)."""
    return math.pi - (math.pi - angle) % math.tau


def _first_max(values: list[float]) -> int:
    """``np.argmax(values)``: the first largest value, or the first NaN."""
    best, k = values[0], 0
    if best != best:
        return 0
    for i in range(1, len(values)):
        value = values[i]
        if value != value:
            return i
        if value > best:
            best, k = value, i
    return k


def sigmoid(z: float) -> float:
    """1 / (1 + e^(−z)), safe for large |z|."""
    if z >= 0:
        return 1.0 / (1.0 + math.exp(-z))
    e = math.exp(z)
    return e / (1.0 + e)


@dataclass(frozen=True)
class BehaviourParameters:
    """What an operator sends to the controller (section 2.2): priorities q_i and velocity limits.

    Distances in metres, ``steepness`` and ``goal_steepness`` in 1/m, gains in rad/s per
    rad (``heading_gain``) and per metre (``centring_gain``).
    """

    priorities: tuple[float, ...] = DEFAULT_PRIORITIES
    v_max: float = 0.12
    omega_max: float = 2.5
    avoid_distance: float = 0.045
    front_distance: float = 0.035
    passage_distance: float = 0.06
    side_offset: float = 0.02
    steepness: float = 200.0
    goal_tolerance: float = 0.015
    goal_steepness: float = 150.0
    heading_gain: float = 3.0
    centring_gain: float = 20.0

    def __post_init__(self) -> None:
        if len(self.priorities) != len(BEHAVIOURS) or not all(q > 0 and math.isfinite(q) for q in self.priorities):
            raise ValueError(f"priorities must be {len(BEHAVIOURS)} finite numbers > 0 (one per behaviour {BEHAVIOURS})")
        for name in ("v_max", "omega_max", "avoid_distance", "front_distance", "passage_distance", "steepness"):
            value = getattr(self, name)
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"BehaviourParameters.{name} must be a finite number > 0, got {value!r}")


@dataclass
class BehaviourStep:
    """One control step: every behaviour's activation, the winner k of eq. (5), and (v, ω) of eq. (6).

    ``levels`` and ``weighted_levels`` are the activations a_i and a_i q_i as lists;
    ``activations`` and ``weighted`` give them as arrays.
    """

    levels: list[float]
    weighted_levels: list[float]
    winner: int
    command: tuple[float, float]

    @property
    def activations(self) -> np.ndarray:
        return np.array(self.levels)

    @property
    def weighted(self) -> np.ndarray:
        return np.array(self.weighted_levels)

    @property
    def winner_name(self) -> str:
        return BEHAVIOURS[self.winner]


@dataclass
class BehaviourController:
    """The controller of Fig. 3 for one robot; ``step`` is called once per control step.

    With ``record=True`` every :class:`BehaviourStep` is appended to ``history`` (the
    activation time plots of Fig. 8; :meth:`activation_history` stacks them).
    """

    params: BehaviourParameters = field(default_factory=BehaviourParameters)
    record: bool = False
    history: list[BehaviourStep] = field(default_factory=list)
    _turn: float = 0.0

    def reset(self) -> None:
        self._turn = 0.0
        self.history.clear()

    def activation_history(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(activations (T, 7), winners (T,), commands (T, 2))`` of the recorded steps."""
        if not self.history:
            return np.zeros((0, len(BEHAVIOURS))), np.zeros(0, dtype=int), np.zeros((0, 2))
        return (
            np.array([h.levels for h in self.history]),
            np.array([h.winner for h in self.history]),
            np.array([h.command for h in self.history]),
        )

    def activations(
        self, pose: tuple[float, float, float], proximity: np.ndarray, target: tuple[float, float] | None, collided: bool = False
    ) -> np.ndarray:
        """The seven activation levels a_i (order of :data:`BEHAVIOURS`)."""
        return np.array(self._levels([float(v) for v in proximity], self._rho(pose, target), collided))

    @staticmethod
    def _rho(pose: tuple[float, float, float], target: tuple[float, float] | None) -> float | None:
        """Distance to the target (``None`` without one)."""
        return None if target is None else math.hypot(target[0] - pose[0], target[1] - pose[1])

    def _levels(self, d: list[float], rho: float | None, collided: bool) -> list[float]:
        """:meth:`activations` from the ray distances ``d`` and the distance ``rho`` to the target (``None``: none)."""
        p = self.params
        d_left = min(d[1], d[0] + p.side_offset)
        d_right = min(d[4], d[5] + p.side_offset)
        d_front = min(d[2], d[3])
        steep = p.steepness
        a = [0.0] * len(BEHAVIOURS)
        a[AVOID_LEFT] = sigmoid(steep * (p.avoid_distance - d_left))
        a[AVOID_RIGHT] = sigmoid(steep * (p.avoid_distance - d_right))
        a[AVOID_FRONT] = sigmoid(steep * (p.front_distance - d_front))
        a[STROLL] = sigmoid(steep * (min(d_left, d_right, d_front) - p.avoid_distance))
        a[NARROW_PASSAGE] = sigmoid(steep * (p.passage_distance - d_left)) * sigmoid(steep * (p.passage_distance - d_right))
        if rho is None:
            a[STOP] = 1.0
        else:
            a[GOAL_TRACKING] = sigmoid(p.goal_steepness * (rho - p.goal_tolerance))
            a[STOP] = 1.0 if collided else sigmoid(p.goal_steepness * (p.goal_tolerance - rho))
        if collided:
            a[STOP] = 1.0
        return a

    def step(
        self,
        pose: tuple[float, float, float],
        proximity: np.ndarray,
        target: tuple[float, float] | None,
        collided: bool = False,
        stroll: bool = False,
    ) -> BehaviourStep:
        """Activations, arbitration (eq. 5) and controls (eq. 6) for one control step.

        Without a target the robot stops (the Wait() operator) unless ``stroll`` is set, in
        which case stop is inactive and the robot strolls, avoiding what it meets.
        """
        d = proximity.tolist() if isinstance(proximity, np.ndarray) else [float(v) for v in proximity]
        rho = self._rho(pose, target)
        a = self._levels(d, rho, collided)
        if target is None and stroll and not collided:
            a[STOP] = 0.0
        weighted = [x * q for x, q in zip(a, self.params.priorities)]
        k = _first_max(weighted)
        if k != AVOID_FRONT:
            self._turn = 0.0
        command = self._command(k, a[k], pose, d, target, rho)
        out = BehaviourStep(a, weighted, k, command)
        if self.record:
            self.history.append(out)
        return out

    def _control(
        self, k: int, a: float, pose: tuple[float, float, float], proximity: np.ndarray, target: tuple[float, float] | None
    ) -> tuple[float, float]:
        """f_k of eq. (6)."""
        return self._command(k, a, pose, [float(v) for v in proximity], target, self._rho(pose, target))

    def _command(
        self,
        k: int,
        a: float,
        pose: tuple[float, float, float],
        d: list[float],
        target: tuple[float, float] | None,
        rho: float | None,
    ) -> tuple[float, float]:
        """:meth:`_control` from the ray distances ``d`` and the target distance ``rho``."""
        p = self.params
        e = 0.0
        if target is None:
            rho = 0.0
        else:
            e = _wrap(math.atan2(target[1] - pose[1], target[0] - pose[0]) - pose[2])
        forward = max(0.0, math.cos(e)) ** 2
        if k == AVOID_LEFT:
            return p.v_max * (1.0 - 0.8 * a), -p.omega_max * a
        if k == AVOID_RIGHT:
            return p.v_max * (1.0 - 0.8 * a), p.omega_max * a
        if k == AVOID_FRONT:
            if self._turn == 0.0:
                left = min(d[0], d[1])
                right = min(d[4], d[5])
                if abs(left - right) > 0.005:
                    self._turn = 1.0 if left > right else -1.0
                else:
                    self._turn = 1.0 if e > 0.1 else -1.0
            return -0.2 * p.v_max * a, self._turn * p.omega_max * a
        if k == GOAL_TRACKING:
            omega = max(-p.omega_max, min(p.omega_max, p.heading_gain * e))
            return min(p.v_max * a * forward, 1.5 * rho), omega
        if k == STROLL:
            return p.v_max * a, 0.0
        if k == NARROW_PASSAGE:
            omega = p.centring_gain * (d[0] - d[5]) + 0.5 * p.heading_gain * e
            omega = max(-p.omega_max, min(p.omega_max, omega))
            v = 0.6 * p.v_max * a * (forward if target is not None else 1.0)
            return (min(v, 1.5 * rho) if target is not None else v), omega
        return 0.0, 0.0
