"""Geometric and topological checks of an :class:`~teamgym.maps.model.OfficeMap`.

:func:`validate` raises :class:`~teamgym.maps.model.MapError` naming the first problem found:
ids, value ranges, sectors outside the workspace or overlapping, doors that touch no sector
(or not the two they claim), overlapping door openings, passages between sectors that do
not touch, furniture that is not convex, leaves its sector, covers a sector's centre point
or a door circle, and a sector/door graph that is disconnected (with every door open, and
with ``always_connected`` also when every door that may be closed, o_j < 1, is closed).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import networkx as nx

from teamgym.maps.geometry import door_opening, on_boundary, shared_edge
from teamgym.maps.model import DoorObject, Furniture, MapError, OfficeMap, Point, Sector
from teamgym.sim.geometry import EPS, convex_overlap, distance_to_polygon, is_convex, point_in_convex


def _mm(p: Point) -> str:
    return f"({p[0] * 1000:.0f}, {p[1] * 1000:.0f}) mm"


def infer_door_sectors(office: OfficeMap, declared: Sequence[bool]) -> OfficeMap:
    """Fill in the sectors of doors that do not declare them: those whose boundary holds the centre."""
    doors = []
    for door, is_declared in zip(office.doors, declared):
        if not is_declared:
            touching = [s.id for s in office.sectors if on_boundary(s, door.centre)]
            if not touching:
                raise MapError(f"{office.source}: door {door.id!r} at {_mm(door.centre)} touches no sector")
            if len(touching) != 2:
                raise MapError(
                    f"{office.source}: door {door.id!r} at {_mm(door.centre)} touches {len(touching)} sector(s) "
                    f"{touching}; a door must lie on the wall between exactly two sectors"
                )
            door = dataclasses.replace(door, sectors=(touching[0], touching[1]))
        doors.append(door)
    return dataclasses.replace(office, doors=tuple(doors))


def topology(office: OfficeMap, closed: Sequence[str] = ()) -> nx.Graph:
    """Unweighted sector/door graph; doors in ``closed`` are left out."""
    graph = nx.Graph()
    graph.add_nodes_from(office.vertex_ids)
    for door in office.doors:
        if door.id not in closed:
            graph.add_edge(door.sectors[0], door.id)
            graph.add_edge(door.id, door.sectors[1])
    graph.add_edges_from(office.passages)
    return graph


def _check_connected(office: OfficeMap, closed: list[str]) -> None:
    graph = topology(office, closed).subgraph(office.sector_ids + [d for d in office.door_ids if d not in closed])
    parts = sorted((sorted(c) for c in nx.connected_components(graph)), key=lambda c: (-len(c), c))
    if len(parts) > 1:
        stranded = [v for part in parts[1:] for v in part if v in office.sector_ids]
        when = f' when door(s) {closed} are closed (open_probability < 1; set "always_connected": false to allow this)'
        raise MapError(
            f"{office.source}: the sector/door graph is disconnected{when if closed else ''}: "
            f"sector(s) {stranded} cannot be reached from {parts[0][0]!r}"
        )


def _check_sector(office: OfficeMap, s: Sector) -> None:
    where = f"{office.source}: sector {s.id!r}"
    w, h = office.size
    if s.x_min < -EPS or s.y_min < -EPS or s.x_max > w + EPS or s.y_max > h + EPS:
        raise MapError(f"{where} reaches outside the {w * 1000:.0f} x {h * 1000:.0f} mm workspace")
    if not 0.0 <= s.clutter < 1.0:
        raise MapError(f"{where}: clutter={s.clutter} is outside [0, 1) (1 would mean not traversable)")
    if not s.contains(*s.centre):
        raise MapError(f"{where}: centre point {_mm(s.centre)} lies outside the sector")


def _check_door(office: OfficeMap, d: DoorObject, sectors: dict[str, Sector]) -> None:
    where = f"{office.source}: door {d.id!r}"
    for sid in d.sectors:
        if sid not in sectors:
            raise MapError(f"{where}: unknown sector {sid!r}; sectors are {list(sectors)}")
    if d.sectors[0] == d.sectors[1]:
        raise MapError(f"{where} joins sector {d.sectors[0]!r} to itself")
    if not 0.0 <= d.open_probability <= 1.0:
        raise MapError(f"{where}: open_probability={d.open_probability} is outside [0, 1]")
    if d.width <= 0 or d.radius <= 0:
        raise MapError(f"{where}: width and radius must be > 0")
    if d.radius < d.width / 2:
        raise MapError(f"{where}: radius {d.radius * 1000:.0f} mm must be at least half the width {d.width * 1000:.0f} mm")
    touching = [sid for sid in d.sectors if on_boundary(sectors[sid], d.centre)]
    if not touching:
        raise MapError(f"{where} at {_mm(d.centre)} touches no sector (declared between {list(d.sectors)})")
    if len(touching) == 1:
        raise MapError(f"{where} at {_mm(d.centre)} touches only sector {touching[0]!r} of its sectors {list(d.sectors)}")
    edge = shared_edge(sectors[d.sectors[0]], sectors[d.sectors[1]])
    if edge is None:
        raise MapError(f"{where}: its sectors {list(d.sectors)} share no wall")
    axis, c, lo, hi = edge
    along = d.centre[1] if axis == "x" else d.centre[0]
    if (
        abs((d.centre[0] if axis == "x" else d.centre[1]) - c) > EPS
        or along - d.width / 2 < lo - EPS
        or along + d.width / 2 > hi + EPS
    ):
        raise MapError(
            f"{where}: the {d.width * 1000:.0f} mm opening at {_mm(d.centre)} does not fit in the wall between its sectors"
        )


def _check_furniture(office: OfficeMap, f: Furniture, sectors: dict[str, Sector]) -> None:
    where = f"{office.source}: furniture {f.id!r}"
    if f.sector not in sectors:
        raise MapError(f"{where}: unknown sector {f.sector!r}")
    if not is_convex(f.vertices):
        raise MapError(f"{where} is not a convex polygon with non-zero area")
    s = sectors[f.sector]
    if not all(s.contains(x, y) for x, y in f.vertices):
        raise MapError(f"{where} leaves its sector {s.id!r}")
    if point_in_convex(f.vertices, s.centre):
        raise MapError(f"{where} covers the centre point of sector {s.id!r}")
    for d in office.doors:
        if distance_to_polygon(f.vertices, d.centre) < d.radius - EPS:
            raise MapError(f"{where} intrudes into the circle of door {d.id!r}")


def check_sectors(office: OfficeMap) -> None:
    """The checks that do not involve doors: ids, sector ranges and overlaps."""
    src = office.source
    if not office.sectors:
        raise MapError(f"{src}: a map needs at least one sector")
    if office.wall_thickness <= 0:
        raise MapError(f"{src}: wall_thickness must be > 0")
    ids = office.vertex_ids
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise MapError(f"{src}: duplicate sector/door id(s) {duplicates}")
    for s in office.sectors:
        _check_sector(office, s)
    for i, a in enumerate(office.sectors):
        for b in office.sectors[i + 1 :]:
            dx = min(a.x_max, b.x_max) - max(a.x_min, b.x_min)
            dy = min(a.y_max, b.y_max) - max(a.y_min, b.y_min)
            if dx > EPS and dy > EPS:
                raise MapError(f"{src}: sectors {a.id!r} and {b.id!r} overlap")


def validate(office: OfficeMap) -> OfficeMap:
    """Check ``office``; return it unchanged or raise :class:`MapError` naming the problem."""
    src = office.source
    check_sectors(office)
    furniture_ids = [f.id for f in office.furniture]
    if len(set(furniture_ids)) != len(furniture_ids):
        raise MapError(f"{src}: duplicate furniture id(s) {sorted({i for i in furniture_ids if furniture_ids.count(i) > 1})}")
    sectors = {s.id: s for s in office.sectors}
    for d in office.doors:
        _check_door(office, d, sectors)
    openings = [(d, door_opening(office, d)) for d in office.doors]
    for i, (d, (axis, c, lo, hi)) in enumerate(openings):
        for e, (axis2, c2, lo2, hi2) in openings[i + 1 :]:
            if axis == axis2 and abs(c - c2) < EPS and min(hi, hi2) - max(lo, lo2) > EPS:
                raise MapError(f"{src}: the openings of doors {d.id!r} and {e.id!r} overlap")
    seen = set()
    for a, b in office.passages:
        for sid in (a, b):
            if sid not in sectors:
                raise MapError(f"{src}: passage {[a, b]}: unknown sector {sid!r}")
        if a == b or frozenset((a, b)) in seen:
            raise MapError(f"{src}: passage {[a, b]} is repeated or joins a sector to itself")
        seen.add(frozenset((a, b)))
        if shared_edge(sectors[a], sectors[b]) is None:
            raise MapError(f"{src}: passage {[a, b]} joins sectors that share no boundary")
        for d in office.doors:
            if set(d.sectors) == {a, b}:
                raise MapError(f"{src}: door {d.id!r} lies on the open passage between {a!r} and {b!r}")
    for f in office.furniture:
        _check_furniture(office, f, sectors)
    for i, f in enumerate(office.furniture):
        for g in office.furniture[i + 1 :]:
            if convex_overlap(f.vertices, g.vertices):
                raise MapError(f"{src}: furniture {f.id!r} and {g.id!r} overlap")
    _check_connected(office, [])
    if office.always_connected:
        uncertain = [d.id for d in office.doors if d.open_probability < 1.0]
        if uncertain:
            _check_connected(office, uncertain)
    return office
