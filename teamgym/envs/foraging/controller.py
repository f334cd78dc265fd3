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

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["GoToController"]

#: Up to this many robots the controller finds the near pairs one by one, above it in one numpy pass.
_SCALAR_ROBOTS = 8


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
        mates: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """``(v, ω)`` per robot (n, 2).

        ``estimate``/``true_pose`` (n, 3); ``aim`` (n, 2): the go-to point in the field frame
        (used through the estimate); ``homing`` (n, 2): measured (distance, bearing) of a target
        to home on, NaN where none (None: no robot homes); ``stop`` (n,) bool (None: none stops);
        ``heading_trig``: cos and sin of the true headings, if known already; ``mates``: the
        offsets (n, n, 2) of every robot from every robot and their lengths (n, n), if known
        already (``true_pose[j] − true_pose[i]``, as the cameras' view computes them).

        The geometry of every robot (go-to distance and bearing) is one numpy pass; the few
        products and sums per robot that follow are scalar float arithmetic (the same IEEE
        operations, in the same order, as the array form they replace), and the turn error
        is one more numpy pass (``np.arctan2``, whose last bit may differ from ``math.atan2`` with
        numpy's AVX-512 kernels); cosines and sines are ``math.cos``/``math.sin`` (libm, as numpy's).
        """
        pairs = self.command_pairs(estimate, true_pose, aim, homing, stop, field_size, heading_trig, mates)
        return np.array(pairs, dtype=float).reshape(len(pairs), 2)

    def command_pairs(
        self,
        estimate: np.ndarray,
        true_pose: np.ndarray,
        aim: np.ndarray,
        homing: np.ndarray | Sequence[tuple[float, float]] | None,
        stop: np.ndarray | Sequence[bool] | None,
        field_size: tuple[float, float],
        heading_trig: tuple[np.ndarray, np.ndarray] | None = None,
        mates: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> list[tuple[float, float]]:
        """:meth:`commands` as a list of ``(v, ω)`` tuples (what the robots' ``set_command`` takes).

        ``homing`` and ``stop`` may also be sequences (rows ``(distance, bearing)``, NaN where none; flags).
        """
        goal = aim - estimate[:, :2]
        gx, gy = goal[:, 0], goal[:, 1]
        distance, bearing = np.hypot(gx, gy).tolist(), (np.arctan2(gy, gx) - estimate[:, 2]).tolist()
        homes = [False] * len(distance)
        if homing is not None:
            for i, (home_d, home_b) in enumerate(homing.tolist() if isinstance(homing, np.ndarray) else homing):
                if home_d == home_d:  # not NaN: home on that target's measured distance and bearing
                    distance[i], bearing[i], homes[i] = home_d, home_b, True
        headings = true_pose[:, 2].tolist()
        if heading_trig is None:
            c, s = [math.cos(h) for h in headings], [math.sin(h) for h in headings]
        else:
            c, s = heading_trig[0].tolist(), heading_trig[1].tolist()
        push_x, push_y = self._pushes(true_pose, field_size, c, s, mates)
        for i, b in enumerate(bearing):  # the aim's direction plus the push (the push added to it, as one sum)
            push_x[i] += math.cos(b)
            push_y[i] += math.sin(b)
        error = np.arctan2(push_y, push_x).tolist()
        top, gain, speed = self.max_turn_rate, self.turn_gain, self.max_speed
        slow, arrive = self.slow_distance, self.arrive_distance
        stops = [False] * len(error) if stop is None else stop.tolist() if isinstance(stop, np.ndarray) else list(stop)
        out = []
        for e, d, stopped, home in zip(error, distance, stops, homes):
            if stopped or (d < arrive and not home):
                out.append((0.0, 0.0))
            else:
                out.append((speed * max(0.0, math.cos(e)) * min(1.0, d / slow), min(max(gain * e, -top), top)))
        return out

    def _pushes(
        self,
        pose: np.ndarray,
        field_size: tuple[float, float],
        c: list[float],
        s: list[float],
        mates: tuple[np.ndarray, np.ndarray] | None,
    ) -> tuple[list[float], list[float]]:
        """Egocentric push (x and y lists over robots) away from near robots and walls; ``c``, ``s``: heading cos, sin."""
        n = len(pose)
        xy = pose[:, :2].tolist()
        push_x, push_y = [0.0] * n, [0.0] * n
        if n > 1:
            if mates is None:
                rel = pose[None, :, :2] - pose[:, None, :2]  # j relative to i
                gap = np.hypot(rel[..., 0], rel[..., 1])
            else:
                rel, gap = mates
            if n <= _SCALAR_ROBOTS:  # few robots: the pairs one by one
                pairs = [
                    (i, j) for i, row in enumerate(gap.tolist()) for j, g in enumerate(row) if g < self.avoid_range and i != j
                ]
            else:
                near = gap < self.avoid_range
                near.flat[:: n + 1] = False
                pairs = list(zip(*(a.tolist() for a in np.nonzero(near))))
            if pairs:
                # Σ_j strength_ij · unit_ij over the near robots j, in index order (the others add zeros).
                scale, gain = self.avoid_range - 2 * self.robot_radius + 1e-9, self.avoid_gain
                world: dict[int, tuple[float, float]] = {}
                for i, j in pairs:
                    (dx, dy), g = rel[i, j].tolist(), float(gap[i, j])
                    strength, length = (self.avoid_range - g) / scale, max(g, 1e-9)
                    term = (strength * (dx / length), strength * (dy / length))
                    world[i] = (world[i][0] + term[0], world[i][1] + term[1]) if i in world else term
                for i, (wx, wy) in world.items():
                    wx, wy = -wx * gain * 2, -wy * gain * 2
                    push_x[i] += wx * c[i] + wy * s[i]
                    push_y[i] += wy * c[i] - wx * s[i]
        # Clearance to the walls x = 0, y = 0 and x = width, y = height, each pushing away.
        width, height = field_size
        radius, reach, gain = self.robot_radius, self.wall_range, self.avoid_gain
        for i, (x, y) in enumerate(xy):
            wx = max((reach - (x - radius)) / reach, 0.0) * gain - max((reach - (width - x - radius)) / reach, 0.0) * gain
            wy = max((reach - (y - radius)) / reach, 0.0) * gain - max((reach - (height - y - radius)) / reach, 0.0) * gain
            push_x[i] += wx * c[i] + wy * s[i]
            push_y[i] += wy * c[i] - wx * s[i]
        return push_x, push_y
