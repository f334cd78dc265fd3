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
        mates: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """``(v, ω)`` per robot (n, 2).

        ``estimate``/``true_pose`` (n, 3); ``aim`` (n, 2): the go-to point in the field frame
        (used through the estimate); ``homing`` (n, 2): measured (distance, bearing) of a target
        to home on, NaN where none (None: no robot homes); ``stop`` (n,) bool (None: none stops);
        ``mates``: the offsets (n, n, 2) of every robot from every robot and their lengths (n, n),
        if known already (``true_pose[j] − true_pose[i]``, as the cameras' view computes them).
        :meth:`command_pairs` on arrays.
        """
        if mates is not None:
            rel, gap = mates
            mates = (rel[..., 0].tolist(), rel[..., 1].tolist(), gap.tolist())
        pairs = self.command_pairs(
            estimate.tolist(),
            true_pose.tolist(),
            aim.tolist(),
            None if homing is None else homing.tolist(),
            None if stop is None else stop.tolist(),
            field_size,
            mates,
        )
        return np.array(pairs, dtype=float).reshape(len(pairs), 2)

    def command_pairs(
        self,
        estimate: Sequence[Sequence[float]],
        true_pose: Sequence[Sequence[float]],
        aim: Sequence[Sequence[float]],
        homing: Sequence[tuple[float, float]] | None,
        stop: Sequence[bool] | None,
        field_size: tuple[float, float],
        mates: tuple[list[list[float]], list[list[float]], list[list[float]]] | None = None,
    ) -> list[tuple[float, float]]:
        """:meth:`commands` of rows as lists, as a list of ``(v, ω)`` tuples (what the robots' ``set_command`` takes).

        ``homing``: rows ``(distance, bearing)``, NaN where none; ``mates``: the teammates' offsets
        as x and y lists and their distances, ``[i][j]`` (robot j seen from robot i).

        The go-to distances are one numpy ``np.hypot`` over the robots (libm's ``hypot``, which
        ``math.hypot`` is not); everything else is scalar float arithmetic in the same IEEE
        operations, in the same order, as the array form (``math.atan2``, ``math.cos`` and
        ``math.sin`` are libm's, as numpy's float64 ones without AVX-512 kernels).
        """
        goal_x = [a[0] - e[0] for a, e in zip(aim, estimate)]
        goal_y = [a[1] - e[1] for a, e in zip(aim, estimate)]
        distance = np.hypot(goal_x, goal_y).tolist()
        atan2, cos, sin = math.atan2, math.cos, math.sin
        bearing = [atan2(gy, gx) - e[2] for gx, gy, e in zip(goal_x, goal_y, estimate)]
        homes = [False] * len(distance)
        if homing is not None:
            for i, (home_d, home_b) in enumerate(homing):
                if home_d == home_d:  # not NaN: home on that target's measured distance and bearing
                    distance[i], bearing[i], homes[i] = home_d, home_b, True
        headings = [p[2] for p in true_pose]
        c, s = [cos(h) for h in headings], [sin(h) for h in headings]
        push_x, push_y = self._pushes(true_pose, field_size, c, s, mates)
        top, gain, speed = self.max_turn_rate, self.turn_gain, self.max_speed
        slow, arrive = self.slow_distance, self.arrive_distance
        stops = [False] * len(distance) if stop is None else stop
        out = []
        for b, px, py, d, stopped, home in zip(bearing, push_x, push_y, distance, stops, homes):
            if stopped or (d < arrive and not home):
                out.append((0.0, 0.0))
            else:  # the aim's direction plus the push (the push added to it, as one sum)
                e = atan2(py + sin(b), px + cos(b))
                out.append((speed * max(0.0, cos(e)) * min(1.0, d / slow), min(max(gain * e, -top), top)))
        return out

    def _pushes(
        self,
        pose: Sequence[Sequence[float]],
        field_size: tuple[float, float],
        c: list[float],
        s: list[float],
        mates: tuple[list[list[float]], list[list[float]], list[list[float]]] | None,
    ) -> tuple[list[float], list[float]]:
        """Egocentric push (x and y lists over robots) away from near robots and walls; ``c``, ``s``: heading cos, sin."""
        n = len(pose)
        push_x, push_y = [0.0] * n, [0.0] * n
        if n > 1:
            if mates is None:
                rel = np.array([p[:2] for p in pose], dtype=float)
                rel = rel[None, :, :] - rel[:, None, :]  # j relative to i
                rel_x, rel_y, gap = rel[..., 0].tolist(), rel[..., 1].tolist(), np.hypot(rel[..., 0], rel[..., 1]).tolist()
            else:
                rel_x, rel_y, gap = mates
            avoid = self.avoid_range
            pairs = [(i, j) for i, row in enumerate(gap) for j, g in enumerate(row) if g < avoid and i != j]
            if pairs:
                # Σ_j strength_ij · unit_ij over the near robots j, in index order (the others add zeros).
                scale, gain = avoid - 2 * self.robot_radius + 1e-9, self.avoid_gain
                world: dict[int, tuple[float, float]] = {}
                for i, j in pairs:
                    dx, dy, g = rel_x[i][j], rel_y[i][j], gap[i][j]
                    strength, length = (avoid - g) / scale, max(g, 1e-9)
                    term = (strength * (dx / length), strength * (dy / length))
                    world[i] = (world[i][0] + term[0], world[i][1] + term[1]) if i in world else term
                for i, (wx, wy) in world.items():
                    wx, wy = -wx * gain * 2, -wy * gain * 2
                    push_x[i] += wx * c[i] + wy * s[i]
                    push_y[i] += wy * c[i] - wx * s[i]
        # Clearance to the walls x = 0, y = 0 and x = width, y = height, each pushing away.
        width, height = field_size
        radius, reach, gain = self.robot_radius, self.wall_range, self.avoid_gain
        for i, p in enumerate(pose):
            x, y = p[0], p[1]
            wx = max((reach - (x - radius)) / reach, 0.0) * gain - max((reach - (width - x - radius)) / reach, 0.0) * gain
            wy = max((reach - (y - radius)) / reach, 0.0) * gain - max((reach - (height - y - radius)) / reach, 0.0) * gain
            push_x[i] += wx * c[i] + wy * s[i]
            push_y[i] += wy * c[i] - wx * s[i]
        return push_x, push_y
