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
