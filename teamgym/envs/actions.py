"""Pluggable action types: how an agent's action becomes a robot command ``(v, ω)``.

An env picks one action type per episode from its config (``action_type``); every type
exposes a gymnasium ``space()`` and converts a validated action with ``command()``. The
``context`` argument carries what a type may need from the env (for the heading set, the
distances of eq. 12 of paper 001).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from teamgym.control.heading import HeadingHeuristic
from teamgym.sim.robot import RobotSpec, body_command


@dataclass(frozen=True)
class CommandContext:
    """Per-robot quantities an action type may use: distance to goal and to the nearest object (m)."""

    target_distance: float = np.inf
    nearest_distance: float = np.inf


class ActionType(ABC):
    """Maps an agent's action to a body command ``(v, ω)`` in SI units."""

    name: str = ""
    #: Whether :meth:`command` reads its ``context`` (the env skips computing it otherwise).
    needs_context: bool = False

    @abstractmethod
    def space(self) -> spaces.Space: ...

    @abstractmethod
    def command(self, action, context: CommandContext) -> tuple[float, float]: ...


class VelocityAction(ActionType):
    """Continuous ``(v, ω)``: linear speed in m/s and angular speed in rad/s (CCW positive)."""

    name = "velocity"

    def __init__(self, spec: RobotSpec) -> None:
        self.v_max = spec.max_speed
        self.omega_max = spec.max_turn_rate

    def space(self) -> spaces.Box:
        high = np.array([self.v_max, self.omega_max], dtype=np.float32)
        return spaces.Box(-high, high, dtype=np.float32)

    def command(self, action, context: CommandContext) -> tuple[float, float]:
        return float(action[0]), float(action[1])


class WheelSpeedAction(ActionType):
    """Continuous wheel rim speeds ``(v_L, v_R)`` in m/s, converted by eq. (6) of paper 001."""

    name = "wheels"

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec

    def space(self) -> spaces.Box:
        high = np.full(2, self.spec.max_wheel_speed, dtype=np.float32)
        return spaces.Box(-high, high, dtype=np.float32)

    def command(self, action, context: CommandContext) -> tuple[float, float]:
        return body_command(float(action[0]), float(action[1]), self.spec.wheel_base)


class HeadingAction(ActionType):
    """Paper 001's decision set (eq. 11): K angular-velocity levels, v from eqs. (12)–(13).

    Level ``k`` of ``K`` is ``ω_k = −ω_max + 2 ω_max k / (K − 1)``; with K = 5 and
    ω_max = 225 deg/s this is the paper's set {−225, −112.5, 0, 112.5, 225} deg/s.
    """

    name = "heading"
    needs_context = True

    def __init__(self, levels: int, max_rate_deg: float, heuristic: HeadingHeuristic) -> None:
        if levels < 2:
            raise ValueError(f"HeadingAction needs at least 2 levels, got {levels}")
        self.rates = np.deg2rad(np.linspace(-max_rate_deg, max_rate_deg, levels))
        self.heuristic = heuristic

    def space(self) -> spaces.Discrete:
        return spaces.Discrete(len(self.rates))

    def command(self, action, context: CommandContext) -> tuple[float, float]:
        v = float(self.heuristic.speed(context.target_distance, context.nearest_distance))
        return v, float(self.rates[int(action)])
