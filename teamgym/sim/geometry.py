"""Plane geometry of convex polygons (metres): convexity, containment, distance, overlap."""

from __future__ import annotations

import math
from collections.abc import Sequence

Point = tuple[float, float]
EPS = 1e-9


def _cross(o: Point, a: Point, b: Point) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def is_convex(vertices: Sequence[Point]) -> bool:
    """Whether the polygon is convex with non-zero area (either orientation)."""
    n = len(vertices)
    if n < 3:
        return False
    signs = {
        math.copysign(1.0, c)
        for i in range(n)
        if abs(c := _cross(vertices[i], vertices[(i + 1) % n], vertices[(i + 2) % n])) > EPS
    }
    area = sum(vertices[i][0] * vertices[(i + 1) % n][1] - vertices[(i + 1) % n][0] * vertices[i][1] for i in range(n))
    return len(signs) == 1 and abs(area) > EPS


def point_in_convex(vertices: Sequence[Point], p: Point) -> bool:
    n = len(vertices)
    crosses = [_cross(vertices[i], vertices[(i + 1) % n], p) for i in range(n)]
    return all(c >= -EPS for c in crosses) or all(c <= EPS for c in crosses)


def distance_to_polygon(vertices: Sequence[Point], p: Point) -> float:
    """Distance from ``p`` to a convex polygon (0 inside)."""
    if point_in_convex(vertices, p):
        return 0.0
    best = math.inf
    n = len(vertices)
    for i in range(n):
        (ax, ay), (bx, by) = vertices[i], vertices[(i + 1) % n]
        dx, dy = bx - ax, by - ay
        t = max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)))
        best = min(best, math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy))
    return best


def convex_overlap(a: Sequence[Point], b: Sequence[Point]) -> bool:
    """Whether two convex polygons overlap with positive area (separating-axis test)."""
    for poly in (a, b):
        for i in range(len(poly)):
            (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % len(poly)]
            nx_, ny_ = y0 - y1, x1 - x0
            pa = [nx_ * x + ny_ * y for x, y in a]
            pb = [nx_ * x + ny_ * y for x, y in b]
            if max(pa) <= min(pb) + EPS or max(pb) <= min(pa) + EPS:
                return False
    return True
