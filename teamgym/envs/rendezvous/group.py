"""Rendezvous's way following and arrival checks as numpy passes over a group of copies (a batch's control step).

A lone :class:`~teamgym.envs.rendezvous.env.Rendezvous` env drives its two or three robots one
by one (:class:`~teamgym.control.way_following.WayFollower`, :func:`~teamgym.envs.rendezvous.actions.nearest_ahead`)
and checks their arrivals and time-outs one by one; a :class:`~teamgym.envs.batch.TeamBatch` of
copies does the same arithmetic here once over every robot of every copy in its stage, with the
same IEEE operations in the same order, so each copy stays bit for bit the lone env with its
seed. ``hypot``, ``atan2``, ``remainder`` and ``cos`` are Python's ``math`` (libm) element by
element, as the lone env computes them (numpy's ``hypot`` and its AVX-512 ``arctan2`` differ in
the last bit; numpy has no IEEE ``remainder``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from teamgym.control.way_following import WayFollower
from teamgym.sim.libm import libm, remainder_tau

__all__ = ["FollowerRows", "arrived", "near_ahead", "way_commands"]


class FollowerRows:
    """The :class:`WayFollower` parameters of each robot row, as arrays ``(n,)``, and the move time-outs.

    ``timeouts``: ``{(robot, from place, to place): seconds}`` (``Rendezvous.move_timeouts``), kept as
    an ``(n, P, P)`` array with ``inf`` where no way joins the places (``places``: how many there are).
    """

    def __init__(self, followers: Sequence[WayFollower], timeouts: dict[tuple[int, int, int], float], places: int) -> None:
        def column(name: str) -> np.ndarray:
            return np.array([getattr(follower, name) for follower in followers], dtype=float)

        self.speed, self.omega_max, self.k_turn = column("speed"), column("omega_max"), column("k_turn")
        self.lookahead, self.brake = column("lookahead"), column("brake")
        self.arrive_tolerance, self.stop_distance = column("arrive_tolerance"), column("stop_distance")
        self._lengths: tuple[np.ndarray, np.ndarray] | None = None
        self.timeouts = np.full((len(followers), places, places), np.inf)
        for (i, a, b), limit in timeouts.items():
            self.timeouts[i, a, b] = limit

    def way_lengths(self, places: np.ndarray) -> np.ndarray:
        """``(P, P)``: ``math.hypot`` of the offset from place ``a`` to place ``b`` (as ``WayFollower._aim`` measures it)."""
        if self._lengths is None or self._lengths[0] is not places:
            dx = places[None, :, 0] - places[:, None, 0]
            dy = places[None, :, 1] - places[:, None, 1]
            self._lengths = (places, libm(math.hypot, dx, dy))
        return self._lengths[1]


def near_ahead(poses: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """``(G, n)`` bool: whether another robot within 60° of a robot's heading is nearer than its ``reach`` (n,):
    :func:`teamgym.envs.rendezvous.actions.nearest_ahead` ``< reach``, bearings computed only for the near pairs."""
    g_count, n = poses.shape[:2]
    out = np.zeros((g_count, n), dtype=bool)
    if n < 2:
        return out
    i, j = np.nonzero(~np.eye(n, dtype=bool))  # ordered pairs, robot i looking at robot j
    x, y = poses[..., 0], poses[..., 1]
    dx, dy = x[:, j] - x[:, i], y[:, j] - y[:, i]  # (G, pairs)
    near = libm(math.hypot, dx, dy) < reach[i]
    if near.any():
        g, pair = np.nonzero(near)
        bearing = remainder_tau(libm(math.atan2, dy[g, pair], dx[g, pair]) - poses[g, i[pair], 2])
        ahead = np.abs(bearing) < math.pi / 3
        out[g[ahead], i[pair][ahead]] = True
    return out


def way_commands(rows: FollowerRows, poses: np.ndarray, origin: np.ndarray, target: np.ndarray, places: np.ndarray) -> np.ndarray:
    """``(v, ω)`` of every robot ``(G, n, 2)``: :meth:`WayFollower.command` along ``origin → target`` (zero where the
    target is −1), each robot with its row's parameters, ``places`` ``(P, 2)`` the places' positions."""
    out = np.zeros((*target.shape, 2))
    moving = target >= 0
    if not moving.any():
        return out
    g, i = np.nonzero(moving)
    ahead = near_ahead(poses, rows.stop_distance)[g, i]
    x, y, theta = poses[g, i, 0], poses[g, i, 1], poses[g, i, 2]
    a, b = origin[g, i], target[g, i]
    start, end = places[a], places[b]
    remaining = libm(math.hypot, end[:, 0] - x, end[:, 1] - y)
    # the pure-pursuit point (WayFollower._aim)
    dx, dy = end[:, 0] - start[:, 0], end[:, 1] - start[:, 1]
    length = rows.way_lengths(places)[a, b]
    degenerate = length < 1e-12
    safe = np.where(degenerate, 1.0, length)
    t = ((x - start[:, 0]) * dx + (y - start[:, 1]) * dy) / safe
    t = np.minimum(length, np.maximum(0.0, t) + rows.lookahead[i])
    aim_x = np.where(degenerate, end[:, 0], start[:, 0] + dx * t / safe)
    aim_y = np.where(degenerate, end[:, 1], start[:, 1] + dy * t / safe)
    error = remainder_tau(libm(math.atan2, aim_y - y, aim_x - x) - theta)
    top = rows.omega_max[i]
    omega = np.maximum(-top, np.minimum(top, rows.k_turn[i] * error))
    v = rows.speed[i] * np.maximum(0.0, libm(math.cos, error)) * np.minimum(1.0, remaining / rows.brake[i])
    halt = (remaining <= rows.arrive_tolerance[i]) | ahead
    out[g, i, 0] = np.where(halt, 0.0, v)
    out[g, i, 1] = np.where(halt, 0.0, omega)
    return out


def arrived(rows: FollowerRows, poses: np.ndarray, target: np.ndarray, places: np.ndarray) -> np.ndarray:
    """``(G, n)`` bool: robots with a target within their arrival tolerance of it (:meth:`WayFollower.arrived`)."""
    out = np.zeros(target.shape, dtype=bool)
    g, i = np.nonzero(target >= 0)
    if len(g):
        end = places[target[g, i]]
        out[g, i] = libm(math.hypot, end[:, 0] - poses[g, i, 0], end[:, 1] - poses[g, i, 1]) <= rows.arrive_tolerance[i]
    return out
