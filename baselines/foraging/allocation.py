"""Target allocation of DMAPS (paper 002, section 4.1): who goes to which known target.

* ``consume``: "the planner pairs up the available robots and targets according to the
  shortest distance method" — :func:`greedy_pairs` repeatedly takes the closest remaining
  robot–target pair (Euclidean distance between positions, m) until robots or targets run out.
* ``surround``: every target needs ``per_target`` robots at once and "all robots go to the
  same known target" — :func:`surround_groups` repeatedly takes the target whose
  ``per_target`` nearest free robots have the smallest total distance and sends those robots to
  it. When fewer than ``per_target`` robots are left they still go (as a smaller group, to the
  target nearest to them in total): a robot's view may lack teammates that will join later.
  Robots left over when no target is left search.

Both are deterministic: ties go to the lower robot index, then the lower target index, so every
robot that computes the allocation on the same view gets the same answer. A robot without a
target gets −1. Plain Python: the sets are small (a few robots and targets) and this is on
every control step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["distances", "greedy_pairs", "surround_groups"]

Points = Sequence[Sequence[float]] | np.ndarray


def _points(points: Points) -> list[tuple[float, float]]:
    if isinstance(points, np.ndarray):
        return [(float(x), float(y)) for x, y in points.reshape(-1, 2).tolist()]
    return [(float(p[0]), float(p[1])) for p in points]


def distances(robots: Points, targets: Points) -> np.ndarray:
    """Euclidean distances ``(m, k)`` between robot positions ``(m, 2)`` and target positions ``(k, 2)``."""
    r, t = _points(robots), _points(targets)
    return np.array([[math.hypot(rx - tx, ry - ty) for tx, ty in t] for rx, ry in r], dtype=float).reshape(len(r), len(t))


def greedy_pairs(robots: Points, targets: Points) -> np.ndarray:
    """Target index ``(m,)`` of every robot by the shortest-distance method (−1: none).

    Taking pairs in order of (distance, robot, target) and keeping those whose robot and
    target are both still free is the same as repeatedly taking the closest remaining pair.
    """
    r, t = _points(robots), _points(targets)
    out = [-1] * len(r)
    pairs = sorted((math.hypot(rx - tx, ry - ty), i, j) for i, (rx, ry) in enumerate(r) for j, (tx, ty) in enumerate(t))
    taken: set[int] = set()
    left = min(len(r), len(t))
    for _, i, j in pairs:
        if left == 0:
            break
        if out[i] < 0 and j not in taken:
            out[i] = j
            taken.add(j)
            left -= 1
    return np.array(out, dtype=np.int64)


def surround_groups(robots: Points, targets: Points, per_target: int) -> np.ndarray:
    """Target index ``(m,)`` of every robot, ``per_target`` robots per target (−1: none); see the module docstring."""
    r, t = _points(robots), _points(targets)
    per_target = max(1, int(per_target))
    d = [[math.hypot(rx - tx, ry - ty) for tx, ty in t] for rx, ry in r]
    out = [-1] * len(r)
    free = list(range(len(r)))
    open_ = list(range(len(t)))
    while open_ and free:
        best = None
        for j in open_:
            group = sorted(free, key=lambda i, j=j: (d[i][j], i))[:per_target]
            cost = sum(d[i][j] for i in group)
            if best is None or cost < best[0] - 1e-12:
                best = (cost, j, group)
        _, j, group = best
        for i in group:
            out[i] = j
        free = [i for i in free if i not in group]
        open_.remove(j)
    return np.array(out, dtype=np.int64)
