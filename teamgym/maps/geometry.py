"""Office geometry: shared sector edges, door openings, and the wall and door segments.

Every sector edge is a wall, except where two sectors are joined by an open passage
(corridor parts) and where a door opening is cut into it; the opening holds a door segment
that the simulator opens and closes. Walls next to an opening are shortened by half the
wall thickness so that the clear width of an open door is exactly its ``width``.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

from teamgym.maps.model import DoorObject, MapError, OfficeMap, Point, Sector
from teamgym.sim.geometry import EPS


def shared_edge(a: Sector, b: Sector) -> tuple[str, float, float, float] | None:
    """The common boundary of two sectors as ``(axis, c, lo, hi)``, or None.

    ``axis == "x"``: the segment ``x = c``, ``lo <= y <= hi``; ``axis == "y"``: ``y = c``,
    ``lo <= x <= hi``. Only boundaries of positive length count.
    """
    for c, other in ((a.x_max, b.x_min), (a.x_min, b.x_max)):
        if abs(c - other) < EPS:
            lo, hi = max(a.y_min, b.y_min), min(a.y_max, b.y_max)
            if hi - lo > EPS:
                return ("x", c, lo, hi)
    for c, other in ((a.y_max, b.y_min), (a.y_min, b.y_max)):
        if abs(c - other) < EPS:
            lo, hi = max(a.x_min, b.x_min), min(a.x_max, b.x_max)
            if hi - lo > EPS:
                return ("y", c, lo, hi)
    return None


def on_boundary(sector: Sector, p: Point) -> bool:
    """Whether ``p`` lies on the rectangle's boundary."""
    x, y = p
    on_vertical = (abs(x - sector.x_min) < EPS or abs(x - sector.x_max) < EPS) and sector.y_min - EPS <= y <= sector.y_max + EPS
    on_horizontal = (abs(y - sector.y_min) < EPS or abs(y - sector.y_max) < EPS) and sector.x_min - EPS <= x <= sector.x_max + EPS
    return on_vertical or on_horizontal


def door_opening(office: OfficeMap, door: DoorObject) -> tuple[str, float, float, float]:
    """The door's opening in the wall as ``(axis, c, lo, hi)`` (see :func:`shared_edge`)."""
    a, b = office.sector(door.sectors[0]), office.sector(door.sectors[1])
    edge = shared_edge(a, b)
    if edge is None:
        raise MapError(f"{office.source}: door {door.id!r}: sectors {door.sectors[0]!r} and {door.sectors[1]!r} do not touch")
    axis, c, _, _ = edge
    along = door.centre[1] if axis == "x" else door.centre[0]
    return axis, c, along - door.width / 2, along + door.width / 2


@dataclass(frozen=True)
class Segment:
    """A straight wall or door segment from ``a`` to ``b`` (metres)."""

    name: str
    a: Point
    b: Point


def _point(axis: str, c: float, t: float) -> Point:
    return (c, t) if axis == "x" else (t, c)


def wall_layout(office: OfficeMap) -> tuple[list[Segment], list[Segment]]:
    """``(walls, doors)``: wall segments and one segment per door opening (named by door id)."""
    lines: dict[tuple[str, float], list[tuple[float, float, str]]] = defaultdict(list)

    def key(axis: str, c: float) -> tuple[str, float]:
        for existing in lines:
            if existing[0] == axis and abs(existing[1] - c) < EPS:
                return existing
        return (axis, c)

    for s in office.sectors:
        lines[key("x", s.x_min)].append((s.y_min, s.y_max, s.id))
        lines[key("x", s.x_max)].append((s.y_min, s.y_max, s.id))
        lines[key("y", s.y_min)].append((s.x_min, s.x_max, s.id))
        lines[key("y", s.y_max)].append((s.x_min, s.x_max, s.id))
    openings: dict[tuple[str, float], list[tuple[float, float, str]]] = defaultdict(list)
    for d in office.doors:
        axis, c, lo, hi = door_opening(office, d)
        openings[key(axis, c)].append((lo, hi, d.id))
    passages = {frozenset(p) for p in office.passages}
    half = office.wall_thickness / 2
    walls: list[Segment] = []
    for (axis, c), spans in sorted(lines.items()):
        doors_here = openings.get((axis, c), [])
        cuts = sorted({t for lo, hi, _ in spans for t in (lo, hi)} | {t for lo, hi, _ in doors_here for t in (lo, hi)})
        pieces: list[tuple[float, float]] = []
        for lo, hi in zip(cuts, cuts[1:]):
            if hi - lo < EPS:
                continue
            mid = 0.5 * (lo + hi)
            owners = {sid for a, b, sid in spans if a - EPS <= mid <= b + EPS}
            if not owners:
                continue
            if len(owners) == 2 and frozenset(owners) in passages:
                continue
            if any(a - EPS <= mid <= b + EPS for a, b, _ in doors_here):
                continue
            if pieces and abs(pieces[-1][1] - lo) < EPS:
                pieces[-1] = (pieces[-1][0], hi)
            else:
                pieces.append((lo, hi))
        edges = {t for lo, hi, _ in doors_here for t in (lo, hi)}
        for lo, hi in pieces:
            lo2 = lo + half if any(abs(lo - t) < EPS for t in edges) else lo
            hi2 = hi - half if any(abs(hi - t) < EPS for t in edges) else hi
            if hi2 - lo2 > EPS:
                walls.append(Segment(f"wall_{len(walls)}", _point(axis, c, lo2), _point(axis, c, hi2)))
    door_segments = []
    for d in office.doors:
        axis, c, lo, hi = door_opening(office, d)
        door_segments.append(Segment(d.id, _point(axis, c, lo), _point(axis, c, hi)))
    return walls, door_segments
