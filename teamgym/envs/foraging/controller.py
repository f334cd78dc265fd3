"""The built-in go-to controller of ``Foraging-v0``'s ``goto_cell`` action (paper 002, section 4.3).

DMAPS outputs a go-to cell and "once the robot is near the target, it relies mainly on the
on-board perception". Every control step, per robot, in its own frame:

* aim: the centre of the go-to cell as seen from the *estimated* pose; if the robot sees a
  target within one cell of the go-to cell, it aims at that detection's measured distance and
  bearing instead (homing, immune to localisation error);
* avoidance: a repulsive push away from every other robot within ``avoid_range`` and from walls
  within ``wall_range``, as a short-range proximity ring would sense them (true geometry);
* stop: in the go-to cell (within ``arrive_distance`` of its centre), or at a target when the
  go-to cell is within one cell of the robot's estimated cell (so a robot stays to consume);
* command: turn towards the combined direction (ω = ``turn_gain`` · error, saturated) and drive
  at ``max_speed`` · max(0, cos error), slowing within ``slow_distance`` of the aim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["GoToController"]


@dataclass(frozen=True)
class GoToController:
    """Gains and ranges of the go-to controller (SI units); see the module docstring."""

    max_speed: float
    max_turn_rate: float
    robot_radius: float
    avoid_range: float = 0.35
    wall_range: float = 0.2
    arrive_distance: float = 0.05
    slow_distance: float = 0.3
    turn_gain: float = 3.0
    avoid_gain: float = 0.6

    def commands(
        self,
        estimate: np.ndarray,
        true_pose: np.ndarray,
        aim: np.ndarray,
        homing: np.ndarray,
        stop: np.ndarray,
        field_size: tuple[float, float],
    ) -> np.ndarray:
        """``(v, ω)`` per robot (n, 2).

        ``estimate``/``true_pose`` (n, 3); ``aim`` (n, 2): the go-to point in the field frame
        (used through the estimate); ``homing`` (n, 2): measured (distance, bearing) of a target
        to home on, NaN where none; ``stop`` (n,) bool.
        """
        n = len(estimate)
        goal = aim - estimate[:, :2]
        distance = np.hypot(goal[:, 0], goal[:, 1])
        bearing = np.arctan2(goal[:, 1], goal[:, 0]) - estimate[:, 2]
        home = ~np.isnan(homing[:, 0])
        distance = np.where(home, homing[:, 0], distance)
        bearing = np.where(home, homing[:, 1], bearing)
        direction = np.stack([np.cos(bearing), np.sin(bearing)], axis=1)
        direction += self._repulsion(true_pose, field_size)
        error = np.arctan2(direction[:, 1], direction[:, 0])
        omega = np.minimum(np.maximum(self.turn_gain * error, -self.max_turn_rate), self.max_turn_rate)
        v = self.max_speed * np.maximum(0.0, np.cos(error)) * np.minimum(1.0, distance / self.slow_distance)
        halt = stop | (~home & (distance < self.arrive_distance))
        out = np.zeros((n, 2))
        out[:, 0] = np.where(halt, 0.0, v)
        out[:, 1] = np.where(halt, 0.0, omega)
        return out

    def _repulsion(self, pose: np.ndarray, field_size: tuple[float, float]) -> np.ndarray:
        """Egocentric push away from near robots and walls (n, 2)."""
        n = len(pose)
        c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        push = np.zeros((n, 2))
        if n > 1:
            rel = pose[None, :, :2] - pose[:, None, :2]  # j relative to i
            gap = np.hypot(rel[..., 0], rel[..., 1])
            np.fill_diagonal(gap, np.inf)
            near = gap < self.avoid_range
            if near.any():
                strength = np.where(near, (self.avoid_range - gap) / (self.avoid_range - 2 * self.robot_radius + 1e-9), 0.0)
                unit = rel / np.maximum(gap, 1e-9)[..., None]
                world = -(strength[..., None] * unit).sum(axis=1) * self.avoid_gain * 2
                push[:, 0] += c * world[:, 0] + s * world[:, 1]
                push[:, 1] += -s * world[:, 0] + c * world[:, 1]
        width, height = field_size
        clearance = np.stack([pose[:, 0], width - pose[:, 0], pose[:, 1], height - pose[:, 1]], axis=1) - self.robot_radius
        normals = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])  # away from each wall
        strength = np.maximum((self.wall_range - clearance) / self.wall_range, 0.0) * self.avoid_gain
        world = strength @ normals
        push[:, 0] += c * world[:, 0] + s * world[:, 1]
        push[:, 1] += -s * world[:, 0] + c * world[:, 1]
        return push
