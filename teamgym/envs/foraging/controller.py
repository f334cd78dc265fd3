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

from teamgym.envs.foraging.frames import to_robot

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
        homing: np.ndarray | None,
        stop: np.ndarray | None,
        field_size: tuple[float, float],
        heading_trig: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """``(v, ω)`` per robot (n, 2).

        ``estimate``/``true_pose`` (n, 3); ``aim`` (n, 2): the go-to point in the field frame
        (used through the estimate); ``homing`` (n, 2): measured (distance, bearing) of a target
        to home on, NaN where none (None: no robot homes); ``stop`` (n,) bool (None: none stops);
        ``heading_trig``: cos and sin of the true headings, if known already.
        """
        goal = aim - estimate[:, :2]
        distance = np.hypot(goal[:, 0], goal[:, 1])
        bearing = np.arctan2(goal[:, 1], goal[:, 0])
        bearing -= estimate[:, 2]
        home = None
        if homing is not None:
            home = ~np.isnan(homing[:, 0])
            distance = np.where(home, homing[:, 0], distance)
            bearing = np.where(home, homing[:, 1], bearing)
        c, s = (np.cos(true_pose[:, 2]), np.sin(true_pose[:, 2])) if heading_trig is None else heading_trig
        push = self._repulsion(true_pose, field_size, c, s)
        push[:, 0] += np.cos(bearing)
        push[:, 1] += np.sin(bearing)  # the aim's direction plus the push (the push added to it, as one sum)
        error = np.arctan2(push[:, 1], push[:, 0])
        omega = np.minimum(np.maximum(self.turn_gain * error, -self.max_turn_rate), self.max_turn_rate)
        v = self.max_speed * np.maximum(0.0, np.cos(error)) * np.minimum(1.0, distance / self.slow_distance)
        halt = distance < self.arrive_distance
        if home is not None:
            halt &= ~home
        if stop is not None:
            halt |= stop
        out = np.empty((len(estimate), 2))
        out[:, 0] = v
        out[:, 1] = omega
        out[halt] = 0.0
        return out

    def _repulsion(self, pose: np.ndarray, field_size: tuple[float, float], c: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Egocentric push away from near robots and walls (n, 2); ``c``, ``s``: cos and sin of the headings."""
        n = len(pose)
        push = np.zeros((n, 2))
        if n > 1:
            rel = pose[None, :, :2] - pose[:, None, :2]  # j relative to i
            gap = np.hypot(rel[..., 0], rel[..., 1])
            gap.flat[:: n + 1] = np.inf
            near = gap < self.avoid_range
            if np.count_nonzero(near):
                strength = np.where(near, (self.avoid_range - gap) / (self.avoid_range - 2 * self.robot_radius + 1e-9), 0.0)
                unit = rel / np.maximum(gap, 1e-9)[..., None]
                world = -(strength[..., None] * unit).sum(axis=1) * self.avoid_gain * 2
                push += to_robot(world, c, s)
        # Clearance to the walls x = 0, y = 0 (row 0) and x = width, y = height (row 1), each pushing away.
        clearance = np.empty((2, n, 2))
        np.subtract(pose[:, :2], self.robot_radius, out=clearance[0])
        np.subtract(field_size, pose[:, :2], out=clearance[1])
        clearance[1] -= self.robot_radius
        strength = np.maximum((self.wall_range - clearance) / self.wall_range, 0.0)
        strength *= self.avoid_gain
        push += to_robot(strength[0] - strength[1], c, s)
        return push
