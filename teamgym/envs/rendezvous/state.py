"""``RendezvousArrays``: the per-episode state of K Rendezvous copies, declared once.

Every array has a leading copy axis ``k`` (then robot ``i``, place ``p`` or way ``w``); a
single :class:`~teamgym.envs.rendezvous.env.Rendezvous` env is the case K = 1 and a
:class:`~teamgym.envs.batch.TeamBatch` binds its copies to rows of one shared object
(:class:`~teamgym.envs.rendezvous.phases.RendezvousPhases`). What does not fit a fixed
shape (the blocker entities in each copy's world, the plans announced so far, the scheduled
blockings) is kept in per-copy lists here too, so the env holds no episode state of its own
besides its world and robots.

The set of blocked ways is a boolean row ``blocked[k]`` plus ``blocked_order[k]``, the ways in
the order they were blocked: obstacles that wait for a way to clear are put in place in the
order in which a Python ``set`` filled in that order iterates (the order the env has always
used, so trajectories do not change).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["RendezvousArrays"]


class RendezvousArrays:
    """Places, moves, known and blocked ways, counters and readings of ``n_copies`` Rendezvous copies."""

    #: Per-copy lists (not arrays): blocker entities by way, ways in blocking order, plan scores,
    #: last PATH announced per agent, scheduled ``(a, b, t)`` blockings still to come, and per
    #: robot the last nearest-place look-up ``(x, y, place, within reach)`` (a cache).
    LISTS = ("blockers", "blocked_order", "plans", "announced", "pending", "nearest_seen")

    def __init__(self, n_robots: int, n_places: int, n_ways: int, ring_width: int, sensor_range: float, n_copies: int) -> None:
        self.shape = (n_robots, n_places, n_ways, ring_width)
        self.sensor_range = sensor_range
        self.n_copies = 0
        for name in self.LISTS:
            setattr(self, name, [])
        self.grow(n_copies)

    # -- storage ---------------------------------------------------------------------
    def _allocate(self, k: int) -> dict[str, np.ndarray]:
        n, p, w, r = self.shape
        return {
            "place": np.zeros((k, n), dtype=np.int64),  # last place reached
            "origin": np.zeros((k, n), dtype=np.int64),  # start of the way being driven
            "target": np.full((k, n), -1, dtype=np.int64),  # end of that way, −1 standing
            "arrived_now": np.zeros((k, n), dtype=bool),
            "move_start": np.zeros((k, n)),
            "collisions": np.zeros((k, n), dtype=np.int64),
            "new_contacts": np.zeros((k, n), dtype=np.int64),
            "failed_moves": np.zeros((k, n), dtype=np.int64),
            "known": np.zeros((k, n, w), dtype=bool),  # ways each robot knows blocked
            "blocked": np.zeros((k, w), dtype=bool),
            "placed": np.zeros((k, w), dtype=bool),  # blocked ways whose obstacle is in the world
            "visits": np.zeros((k, p), dtype=np.int64),
            "robot_collisions": np.zeros(k, dtype=np.int64),
            "met": np.zeros(k, dtype=bool),
            "meeting_time": np.full(k, math.nan),
            "stale_plans": np.zeros(k, dtype=np.int64),
            "expansions": np.zeros(k, dtype=np.int64),
            "distance": np.zeros(k),  # mean distance between robots at the last control step
            "any_contact": np.zeros(k, dtype=bool),  # the last control step had contacts
            "rings_due": np.zeros(k, dtype=bool),  # noiseless rings to read when observed
            "proximity": np.full((k, n, r), self.sensor_range, dtype=np.float32),
        }

    def arrays(self) -> list[str]:
        """The names of the arrays (each with the leading copy axis)."""
        return list(self._allocate(0))

    def grow(self, n_copies: int) -> None:
        """Make room for ``n_copies`` copies (existing copies keep their rows)."""
        extra = n_copies - self.n_copies
        if extra <= 0:
            return
        for name, block in self._allocate(extra).items():
            old = getattr(self, name, None)
            setattr(self, name, block if old is None else np.concatenate([old, block]))
        for name in self.LISTS:
            getattr(self, name).extend(self._fresh_list(name) for _ in range(extra))
        self.n_copies = n_copies

    def shrink(self, n_copies: int) -> None:
        """Keep only the first ``n_copies`` copies."""
        if n_copies >= self.n_copies:
            return
        for name in self.arrays():
            setattr(self, name, getattr(self, name)[:n_copies].copy())
        for name in self.LISTS:
            del getattr(self, name)[n_copies:]
        self.n_copies = n_copies

    def _fresh_list(self, name: str) -> Any:
        if name == "blockers" or name == "announced":
            return {}
        if name == "nearest_seen":
            return [()] * self.shape[0]
        return []

    def start(self, k: int, starts: np.ndarray, blockings: list[tuple[str, str, float]]) -> None:
        """A new episode in copy ``k``: robots at places ``starts``, nothing known, ``blockings`` scheduled."""
        for name, block in self._allocate(1).items():
            getattr(self, name)[k] = block[0]
        self.place[k] = starts
        self.origin[k] = starts
        for name in self.LISTS:
            getattr(self, name)[k] = self._fresh_list(name)
        self.pending[k] = list(blockings)

    # -- one copy's rows, for snapshots ------------------------------------------------
    def row(self, k: int) -> dict[str, Any]:
        """Copy ``k``'s state (copies of its rows and lists): what a snapshot of that copy holds."""
        state: dict[str, Any] = {name: getattr(self, name)[k].copy() for name in self.arrays()}
        for name in self.LISTS:
            state[name] = _copied(getattr(self, name)[k])
        return state

    def set_row(self, k: int, state: dict[str, Any]) -> None:
        """Copy ``k`` takes ``state`` (from :meth:`row`)."""
        for name in self.arrays():
            getattr(self, name)[k] = state[name]
        for name in self.LISTS:
            getattr(self, name)[k] = state[name]

    # -- blocked ways ----------------------------------------------------------------
    def block(self, k: int, way: int) -> bool:
        """Mark ``way`` blocked in copy ``k``; False if it already was."""
        if self.blocked[k, way]:
            return False
        self.blocked[k, way] = True
        self.blocked_order[k].append(way)
        return True

    def blocked_set(self, k: int) -> set[int]:
        """Copy ``k``'s blocked ways as the set the env has always kept (filled in blocking order)."""
        return set(self.blocked_order[k])

    def on_way(self, k: int, ends: tuple[int, int]) -> bool:
        """Whether a robot of copy ``k`` is driving the way between places ``ends`` (either direction)."""
        a, b = ends
        for origin, target in zip(self.origin[k].tolist(), self.target[k].tolist()):
            if target >= 0 and ((origin == a and target == b) or (origin == b and target == a)):
                return True
        return False


def _copied(value: Any) -> Any:
    if isinstance(value, dict):
        return {key: list(v) if isinstance(v, list) else v for key, v in value.items()}
    return list(value)
