"""Trails (an env's per-cycle positions) packed for pickling, each point converted once.

An env appends ``(x, y)`` to a list per robot, obstacle or box every control cycle, so an
episode's trails grow with its length. :class:`TrailArchive` keeps float64 arrays of the
points it has already packed, per trail, and on each :meth:`TrailArchive.pack` converts only
the points appended since; pickling arrays costs next to nothing per point. A trail list is
append-only while its archive entry lives (a new list under the same name starts over).
"""

from __future__ import annotations

import numpy as np

__all__ = ["TrailArchive"]

Trails = dict[str, list[tuple[float, float]]]
Packed = dict[str, list[np.ndarray]]
_MAX_CHUNKS = 16


class TrailArchive:
    """Packed copies of append-only trails (see the module docstring)."""

    def __init__(self) -> None:
        #: name -> (the trail list, packed chunks, number of points packed)
        self._entries: dict[str, tuple[list, list[np.ndarray], int]] = {}

    def pack(self, trails: Trails) -> Packed:
        """Every trail as float64 ``(n, 2)`` chunks (read-only; shared with the archive)."""
        entries, packed = {}, {}
        for name, points in trails.items():
            entry = self._entries.get(name)
            if entry is None or entry[0] is not points or entry[2] > len(points):
                entry = (points, [], 0)
            _, chunks, done = entry
            if len(points) > done:
                chunk = np.array(points[done:], dtype=float).reshape(-1, 2)
                chunk.flags.writeable = False
                chunks = [*chunks, chunk]
                if len(chunks) > _MAX_CHUNKS:
                    merged = np.concatenate(chunks)
                    merged.flags.writeable = False
                    chunks = [merged]
            entries[name] = (points, chunks, len(points))
            packed[name] = chunks
        self._entries = entries
        return packed

    @classmethod
    def unpack(cls, packed: Packed) -> tuple[Trails, TrailArchive]:
        """Trail lists from :meth:`pack`'s output, and an archive that already holds them."""
        archive = cls()
        trails = {}
        for name, chunks in packed.items():
            points = list(map(tuple, np.concatenate(chunks).tolist())) if chunks else []
            trails[name] = points
            archive._entries[name] = (points, list(chunks), len(points))
        return trails, archive

    def copied(self, trails: Trails) -> tuple[Trails, TrailArchive]:
        """Copies of ``trails`` (new lists of the same points) and an archive for them that keeps what this one packed."""
        archive = type(self)()
        copies = {}
        for name, points in trails.items():
            copies[name] = list(points)
            entry = self._entries.get(name)
            if entry is not None and entry[0] is points and entry[2] <= len(points):
                archive._entries[name] = (copies[name], entry[1], entry[2])
        return copies, archive
