"""Geometry of Rendezvous-v0: corridor walls around the ways of a graph map, and way blockers.

The free space is the union of a disc at every place and a corridor along every way (both
``corridor_width`` wide, shapely buffers); its boundary becomes the wall segments of the
pymunk world. A blocked way gets a square blocker in the middle of its corridor.
"""

from __future__ import annotations

import math

import shapely
from shapely.geometry import LineString, Point

from teamgym.maps.graph import GraphMap

Segment = tuple[tuple[float, float], tuple[float, float]]


def corridor_walls(graph_map: GraphMap, scale: float, width: float, margin: float) -> list[Segment]:
    """Wall segments (world metres) bounding the corridors and place discs of ``graph_map``."""
    half = width / 2
    shapes = [Point(margin + p.x * scale, margin + p.y * scale).buffer(half * 1.2, quad_segs=4) for p in graph_map.places]
    for way in graph_map.ways:
        a, b = graph_map.place(way.a), graph_map.place(way.b)
        line = LineString([(margin + a.x * scale, margin + a.y * scale), (margin + b.x * scale, margin + b.y * scale)])
        shapes.append(line.buffer(half, cap_style="flat"))
    free = shapely.union_all(shapes).simplify(1e-4)
    segments: list[Segment] = []
    for polygon in getattr(free, "geoms", [free]):
        for ring in [polygon.exterior, *polygon.interiors]:
            coords = list(ring.coords)
            segments += [(tuple(p), tuple(q)) for p, q in zip(coords, coords[1:]) if math.dist(p, q) > 1e-6]
    return segments


def blocker_vertices(a: tuple[float, float], b: tuple[float, float], width: float) -> list[tuple[float, float]]:
    """A square in the middle of way ``a–b``, aligned with it: side ``0.8 · width``, at most a
    third of the way's length (so that it never covers the places at its ends)."""
    mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
    angle = math.atan2(b[1] - a[1], b[0] - a[0])
    c, s, h = math.cos(angle), math.sin(angle), min(0.4 * width, math.dist(a, b) / 6)
    return [(mx + c * dx - s * dy, my + s * dx + c * dy) for dx, dy in ((-h, -h), (h, -h), (h, h), (-h, h))]
