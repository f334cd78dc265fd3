"""Way following on a graph map: drive a differential-drive robot along a straight way.

The robot tracks the segment from the way's start place to its end place with a pure-pursuit
rule: it aims at the point ``lookahead`` metres further along the segment than its own
projection (the end place once that is closer), turns with ``ω = k_turn · e`` (``e`` the
heading error, saturated at ``omega_max``) and drives with ``v = speed · max(0, cos e)`` —
it turns on the spot when the target is behind it — slowing down over the last ``brake``
metres. It has arrived when its centre is within ``arrive_tolerance`` of the end place.

A robot that is about to meet its partner stops (the "approaching procedure" of paper 003,
Steps 4 and 8): the env passes the distance to the nearest other robot ahead, and the
command is zero once it is below ``stop_distance``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class WayFollower:
    """Parameters of the way-following controller (SI units)."""

    speed: float = 0.1
    omega_max: float = 3.0
    k_turn: float = 4.0
    lookahead: float = 0.05
    brake: float = 0.04
    arrive_tolerance: float = 0.01
    stop_distance: float = 0.08

    def command(
        self,
        pose: tuple[float, float, float],
        start: tuple[float, float],
        end: tuple[float, float],
        nearest_ahead: float = math.inf,
    ) -> tuple[float, float]:
        """``(v, ω)`` that moves the robot at ``pose`` along ``start → end``."""
        x, y, theta = pose
        remaining = math.hypot(end[0] - x, end[1] - y)
        if remaining <= self.arrive_tolerance or nearest_ahead < self.stop_distance:  # arrived, or about to meet
            return 0.0, 0.0
        aim = self._aim(x, y, start, end)
        error = math.remainder(math.atan2(aim[1] - y, aim[0] - x) - theta, math.tau)
        omega = max(-self.omega_max, min(self.omega_max, self.k_turn * error))
        v = self.speed * max(0.0, math.cos(error)) * min(1.0, remaining / self.brake)
        return v, omega

    def arrived(self, pose: tuple[float, float, float], end: tuple[float, float]) -> bool:
        return math.hypot(end[0] - pose[0], end[1] - pose[1]) <= self.arrive_tolerance

    def _aim(self, x: float, y: float, start: tuple[float, float], end: tuple[float, float]) -> tuple[float, float]:
        """The pure-pursuit point: ``lookahead`` beyond the robot's projection on the segment."""
        dx, dy = end[0] - start[0], end[1] - start[1]
        length = math.hypot(dx, dy)
        if length < 1e-12:
            return end
        t = ((x - start[0]) * dx + (y - start[1]) * dy) / length
        t = min(length, max(0.0, t) + self.lookahead)
        return (start[0] + dx * t / length, start[1] + dy * t / length)
