"""Map abstractions (paper 003, section 2): from a polygonal workspace to a :class:`GraphMap`.

A :class:`Workspace` is the rectangle ``[0, w] × [0, h]`` (m, y up) minus polygonal obstacles.
Two of the paper's abstractions turn it into places and ways:

* :func:`cell_decomposition` (Fig. 1): a triangular partition of the free space, one place
  per triangle, one way per pair of triangles sharing an edge;
* :func:`voronoi_roadmap` (Fig. 2): the Voronoi diagram of points on the obstacle outlines,
  keeping the segments a robot of the given clearance can follow.

Random generators for experiments: :func:`random_grid_map`, :func:`random_workspace` and
:func:`random_voronoi_map`. The maps are valid by construction (the tests run
:func:`~teamgym.maps.graph.validate_graph_map` on them; the builders skip it, as it is slow on
10,000 places); place ids are ``"0"``, ``"1"``, ... Random generators take a
``numpy.random.Generator`` (or a seed).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon, box
from shapely.ops import unary_union

from teamgym.maps.graph import GraphMap, Place, Way

Point = tuple[float, float]

DEFAULT_CLEARANCE = 0.055
"""Clearance (m) of :func:`random_voronoi_map`: the diameter of teamgym's default robot (radius 0.0275 m)."""


@dataclass(frozen=True)
class Workspace:
    """The rectangle ``[0, width] × [0, height]`` (m) minus polygonal ``obstacles``.

    An obstacle is a simple polygon given by its vertices (at least 3, either orientation, not
    repeated at the end). Obstacles may overlap or reach past the walls: the free space is
    what remains of the rectangle.
    """

    width: float
    height: float
    obstacles: tuple[tuple[Point, ...], ...] = ()

    def __post_init__(self) -> None:
        for key in ("width", "height"):
            value = getattr(self, key)
            if not _positive(value):
                raise ValueError(f"Workspace.{key} must be a finite number > 0, got {value!r}")
        obstacles = tuple(_vertices(i, poly) for i, poly in enumerate(self.obstacles))
        object.__setattr__(self, "obstacles", obstacles)
        for i, poly in enumerate(obstacles):
            polygon = Polygon(poly)
            if not polygon.is_valid or polygon.area <= 0:
                raise ValueError(f"Workspace obstacle {i} is not a simple polygon: {shapely.is_valid_reason(polygon)}")

    @property
    def size(self) -> tuple[float, float]:
        return (float(self.width), float(self.height))

    @cached_property
    def obstacle_region(self) -> shapely.Geometry:
        """Union of the obstacles (an empty geometry if there are none)."""
        return unary_union([Polygon(p) for p in self.obstacles])

    @cached_property
    def free_space(self) -> Polygon | MultiPolygon:
        """The rectangle minus the obstacles (a MultiPolygon if the obstacles cut it in parts)."""
        return box(0.0, 0.0, self.width, self.height).difference(self.obstacle_region)


def _positive(value: object) -> bool:
    """Whether ``value`` is a finite real number > 0 (not a bool)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value) and value > 0


def _vertices(index: int, poly: Sequence[Sequence[float]]) -> tuple[Point, ...]:
    try:
        vertices = tuple((float(x), float(y)) for x, y in poly)
    except (TypeError, ValueError):
        raise TypeError(f"Workspace obstacle {index}: expected a list of (x, y) vertices, got {poly!r}") from None
    if len(vertices) < 3 or not all(math.isfinite(v) for xy in vertices for v in xy):
        raise ValueError(f"Workspace obstacle {index}: needs at least 3 finite (x, y) vertices, got {poly!r}")
    return vertices


# -- cell decomposition (Fig. 1) ---------------------------------------------------------


def triangulate_free_space(workspace: Workspace) -> list[Polygon]:
    """Triangles partitioning the free space: shapely's (GEOS) constrained Delaunay triangulation.

    Corners are the outline vertices (no new points); triangles cover the free space exactly and
    never overlap an obstacle.
    """
    return list(shapely.get_parts(shapely.constrained_delaunay_triangles(_free_space(workspace))))


def _free_space(workspace: Workspace) -> Polygon | MultiPolygon:
    if workspace.free_space.is_empty:
        raise ValueError(f"the obstacles cover the whole {workspace.width:g} x {workspace.height:g} m workspace")
    return workspace.free_space


def cell_decomposition(workspace: Workspace, name: str = "cells") -> GraphMap:
    """Triangular partition of the free space as a graph map (paper 003, Fig. 1).

    Place ``"i"`` is the centroid of triangle ``i`` of :func:`triangulate_free_space`; a way
    joins two triangles sharing an edge. Its ``length`` is the straight-line distance between
    the centroids (which a skinny pair of triangles may route outside their union) and its
    ``width`` the length of the shared edge, the facet a robot crosses. If the obstacles cut
    the free space in parts, the map is marked ``allow_disconnected``.
    """
    triangles = triangulate_free_space(workspace)
    places = tuple(Place(str(i), float(t.centroid.x), float(t.centroid.y)) for i, t in enumerate(triangles))
    ways = tuple(Way(str(i), str(j), width=width) for i, j, width in _shared_edges(triangles))
    parts = len(shapely.get_parts(workspace.free_space))
    description = f"Cell decomposition: {len(places)} triangles of the free space, {len(workspace.obstacles)} obstacle(s)."
    return GraphMap(name, places, ways, workspace.size, allow_disconnected=parts > 1, description=description)


def _shared_edges(triangles: Sequence[Polygon]) -> list[tuple[int, int, float]]:
    """``(i, j, edge length)`` for each pair of triangles ``i < j`` with a common edge."""
    owners: dict[frozenset[Point], list[int]] = {}
    for i, triangle in enumerate(triangles):
        corners = [tuple(c) for c in shapely.get_coordinates(triangle)[:3]]
        for k in range(3):
            owners.setdefault(frozenset((corners[k], corners[k - 1])), []).append(i)
    shared = []
    for edge, owner in owners.items():
        if len(owner) == 2:
            p, q = tuple(edge)
            shared.append((min(owner), max(owner), math.dist(p, q)))
    return sorted(shared)


# -- Voronoi roadmap (Fig. 2) ------------------------------------------------------------


def voronoi_roadmap(workspace: Workspace, clearance: float, spacing: float | None = None, name: str = "voronoi") -> GraphMap:
    """Voronoi roadmap of the free space (paper 003, Fig. 2) for a robot needing ``clearance`` (m).

    Points are sampled every ``spacing`` m (default ``clearance / 2``) along the walls and the
    obstacle outlines, corners included (the paper uses Harris corners of an overhead image).
    A vertex of their Voronoi diagram (scipy) is a place and a finite ridge a way if the whole
    segment lies in the free space at least ``clearance`` (a robot's diameter) from every
    obstacle and wall. Vertices closer than ``spacing / 4`` are merged; only the largest
    connected part is kept. A way's ``length`` is its segment's, its ``width`` twice the
    segment's distance to the nearest obstacle or wall. Raises ValueError if no way is left.
    """
    from scipy.spatial import Voronoi

    clearance, spacing = _check_voronoi_args(clearance, spacing)
    free = _free_space(workspace)
    shapely.prepare(free)
    vor = Voronoi(_boundary_points(free, spacing))
    vertices, ridges = _inside(vor.vertices, _finite_ridges(vor), free)
    vertices, ridges = _merge_close(vertices, ridges, spacing / 4)
    vertices, ridges = _inside(vertices, ridges, free)
    width = 2 * _segment_clearance(vertices, ridges, _edge_tree(free))
    keep = width >= 2 * clearance
    ridges, width = ridges[keep], width[keep]
    if len(ridges) == 0:
        raise ValueError(f"voronoi_roadmap: no Voronoi segment keeps clearance {clearance:g} m from the obstacles and walls")
    return _roadmap_map(workspace, vertices, ridges, width, name, f"clearance {clearance:g} m, spacing {spacing:g} m")


def _check_voronoi_args(clearance: float, spacing: float | None) -> tuple[float, float]:
    if not _positive(clearance):
        raise ValueError(f"voronoi_roadmap: clearance must be a finite number > 0 (m), got {clearance!r}")
    spacing = clearance / 2 if spacing is None else spacing
    if not _positive(spacing):
        raise ValueError(f"voronoi_roadmap: spacing must be a finite number > 0 (m), got {spacing!r}")
    return float(clearance), float(spacing)


def _boundary_points(free: shapely.Geometry, spacing: float) -> np.ndarray:
    """Points at most ``spacing`` apart along the outline of ``free``, corners included, without repeats."""
    return np.unique(shapely.get_coordinates(shapely.segmentize(free.boundary, spacing)), axis=0)


def _finite_ridges(vor: Any) -> np.ndarray:
    """The ridges of a ``scipy.spatial.Voronoi`` diagram with both ends finite, as vertex index pairs."""
    ridges = np.asarray(vor.ridge_vertices, dtype=np.int64).reshape(-1, 2)
    return ridges[(ridges >= 0).all(axis=1)]


def _inside(vertices: np.ndarray, ridges: np.ndarray, free: shapely.Geometry) -> tuple[np.ndarray, np.ndarray]:
    """The ridges whose two ends lie in the interior of ``free``."""
    inside = shapely.contains_xy(free, vertices[:, 0], vertices[:, 1])
    return vertices, ridges[inside[ridges].all(axis=1)]


def _merge_close(vertices: np.ndarray, ridges: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge the vertices within ``radius`` of each other (chains too) into their mean; drop loops and repeats."""
    from scipy.spatial import cKDTree

    pairs = cKDTree(vertices).query_pairs(radius, output_type="ndarray").reshape(-1, 2)
    count, label = _components(pairs, len(vertices))
    merged = np.zeros((count, 2))
    np.add.at(merged, label, vertices)
    merged /= np.bincount(label, minlength=count)[:, None]
    ridges = np.sort(label[ridges], axis=1)
    ridges = np.unique(ridges[ridges[:, 0] != ridges[:, 1]], axis=0)
    return merged, ridges.reshape(-1, 2)


def _edge_tree(free: shapely.Geometry) -> shapely.STRtree:
    """An STRtree of the outline's straight edges (walls and obstacle sides)."""
    edges = []
    for ring in shapely.get_parts(free.boundary):
        xy = shapely.get_coordinates(ring)
        edges.append(np.stack([xy[:-1], xy[1:]], axis=1))
    return shapely.STRtree(shapely.linestrings(np.concatenate(edges)))


def _segment_clearance(vertices: np.ndarray, ridges: np.ndarray, tree: shapely.STRtree) -> np.ndarray:
    """Distance (m) from each ridge segment to the nearest outline edge."""
    if len(ridges) == 0:
        return np.zeros(0)
    segments = shapely.linestrings(vertices[ridges])
    (which, _), distance = tree.query_nearest(segments, return_distance=True, all_matches=False)
    clearance = np.empty(len(ridges))
    clearance[which] = distance
    return clearance


def _components(pairs: np.ndarray, n: int) -> tuple[int, np.ndarray]:
    """Number of connected parts of the graph on ``n`` nodes with edges ``pairs``, and each node's part."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    links = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    count, label = connected_components(links, directed=False)
    return int(count), label


def _largest_part(ridges: np.ndarray, n: int) -> np.ndarray:
    """Mask of the ridges in the largest connected part (the first such part on ties)."""
    _, label = _components(ridges, n)
    sizes = np.bincount(label[np.unique(ridges)])
    return label[ridges[:, 0]] == int(np.argmax(sizes))


def _roadmap_map(
    workspace: Workspace, vertices: np.ndarray, ridges: np.ndarray, width: np.ndarray, name: str, params: str
) -> GraphMap:
    """The largest connected part of the ridges as a GraphMap, places numbered by (x, y)."""
    keep = _largest_part(ridges, len(vertices))
    ridges, width = ridges[keep], width[keep]
    used = np.unique(ridges)
    used = used[np.lexsort((vertices[used, 1], vertices[used, 0]))]
    index = np.full(len(vertices), -1)
    index[used] = np.arange(len(used))
    places = tuple(Place(str(i), float(x), float(y)) for i, (x, y) in enumerate(vertices[used]))
    ways = tuple(Way(str(index[a]), str(index[b]), width=float(w)) for (a, b), w in zip(ridges, width))
    description = f"Voronoi roadmap ({params}) of a workspace with {len(workspace.obstacles)} obstacle(s)."
    return GraphMap(name, places, ways, workspace.size, description=description)


# -- random maps -------------------------------------------------------------------------


def random_grid_map(
    n_places: int,
    rng: np.random.Generator | int | None = None,
    drop: float = 0.2,
    diagonals: float = 0.0,
    name: str = "grid",
) -> GraphMap:
    """A connected grid of exactly ``n_places`` places 1 m apart, some ways removed.

    Places fill rows of ``ceil(sqrt(n_places))`` from the bottom (the top row may be partial),
    at ``(col + 0.5, row + 0.5)``. Each unit square with four places gets, with probability
    ``diagonals``, one diagonal way (length √2, random direction). Then ``round(drop × ways)``
    ways are removed at random among those off a random spanning tree, so the map stays
    connected (all off-tree ways go if there are fewer).
    """
    n_places = _count("random_grid_map", "n_places", n_places)
    for key, value in (("drop", drop), ("diagonals", diagonals)):
        if not (isinstance(value, numbers.Real) and 0.0 <= value <= 1.0):
            raise ValueError(f"random_grid_map: {key} must be a probability in [0, 1], got {value!r}")
    rng = np.random.default_rng(rng)
    cols = math.ceil(math.sqrt(n_places))
    edges = _grid_edges(n_places, cols) + _grid_diagonals(n_places, cols, diagonals, rng)
    edges = _drop_off_tree(edges, n_places, round(drop * len(edges)), rng)
    places = tuple(Place(str(i), i % cols + 0.5, i // cols + 0.5) for i in range(n_places))
    ways = tuple(Way(str(a), str(b)) for a, b in edges)
    size = (float(cols), float(math.ceil(n_places / cols)))
    description = f"Random grid: {n_places} places, diagonals {diagonals:g}, drop {drop:g}."
    return GraphMap(name, places, ways, size, description=description)


def _count(func: str, key: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{func}: {key} must be an integer >= 1, got {value!r}")
    return int(value)


def _grid_edges(n: int, cols: int) -> list[tuple[int, int]]:
    right = [(i, i + 1) for i in range(n - 1) if (i + 1) % cols]
    up = [(i, i + cols) for i in range(n - cols)]
    return right + up


def _grid_diagonals(n: int, cols: int, probability: float, rng: np.random.Generator) -> list[tuple[int, int]]:
    corners = [i for i in range(n - cols - 1) if (i + 1) % cols]  # bottom-left corners of full unit squares
    chosen = rng.random(len(corners)) < probability
    rising = rng.random(len(corners)) < 0.5
    return [(i, i + cols + 1) if up else (i + 1, i + cols) for i, pick, up in zip(corners, chosen, rising) if pick]


def _drop_off_tree(edges: list[tuple[int, int]], n: int, count: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    """``edges`` minus ``count`` random ones that are not on a random spanning tree (Kruskal on a shuffle)."""
    order = rng.permutation(len(edges))
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    spare = []
    for k in order:
        a, b = root(edges[k][0]), root(edges[k][1])
        if a == b:
            spare.append(k)
        else:
            parent[a] = b
    removed = set(spare[:count])
    return [e for k, e in enumerate(edges) if k not in removed]


def random_workspace(
    rng: np.random.Generator | int | None,
    n_obstacles: int,
    size: float | tuple[float, float] = (10.0, 10.0),
    radius: tuple[float, float] = (0.3, 1.0),
    gap: float = 0.5,
) -> Workspace:
    """A workspace with ``n_obstacles`` random convex polygons (3 to 7 vertices) kept apart.

    Obstacle ``k`` is inscribed in a disc of radius drawn from ``radius`` (m); the discs are at
    least ``gap`` m from each other and from the walls, so every passage is at least ``gap``
    wide and the free space is connected. Raises ValueError if they do not fit.
    """
    w, h = _check_workspace_args(n_obstacles, size, radius, gap)
    rng = np.random.default_rng(rng)
    centres, radii, obstacles = np.zeros((0, 2)), np.zeros(0), []
    for k in range(int(n_obstacles)):
        centre, r = _place_disc(rng, (w, h), radius, gap, centres, radii, k)
        centres, radii = np.vstack([centres, centre]), np.append(radii, r)
        angles = np.sort(rng.uniform(0.0, 2 * math.pi, int(rng.integers(3, 8))))
        obstacles.append(tuple((float(x), float(y)) for x, y in centre + r * np.column_stack([np.cos(angles), np.sin(angles)])))
    return Workspace(float(w), float(h), tuple(obstacles))


def _check_workspace_args(
    n_obstacles: int, size: float | tuple[float, float], radius: tuple[float, float], gap: float
) -> tuple[float, float]:
    """``(w, h)``; ValueError naming the first bad argument of :func:`random_workspace`."""
    if isinstance(n_obstacles, bool) or not isinstance(n_obstacles, (int, np.integer)) or n_obstacles < 0:
        raise ValueError(f"random_workspace: n_obstacles must be an integer >= 0, got {n_obstacles!r}")
    w, h = (size, size) if isinstance(size, numbers.Real) else tuple(size)
    if not (_positive(w) and _positive(h)):
        raise ValueError(f"random_workspace: size must be > 0 (m), got {size!r}")
    if len(radius) != 2 or not (_positive(radius[0]) and _positive(radius[1]) and radius[0] <= radius[1]):
        raise ValueError(f"random_workspace: radius must be (low, high) with 0 < low <= high (m), got {radius!r}")
    if not (isinstance(gap, numbers.Real) and math.isfinite(gap) and gap >= 0):
        raise ValueError(f"random_workspace: gap must be a finite number >= 0 (m), got {gap!r}")
    return float(w), float(h)


def _place_disc(
    rng: np.random.Generator,
    size: tuple[float, float],
    radius: tuple[float, float],
    gap: float,
    centres: np.ndarray,
    radii: np.ndarray,
    k: int,
    tries: int = 1000,
) -> tuple[np.ndarray, float]:
    """A disc (centre, radius) inside ``size`` with ``gap`` to the walls and to the given discs."""
    w, h = size
    for _ in range(tries):
        r = float(rng.uniform(*radius))
        if 2 * (r + gap) > min(w, h):
            continue
        centre = rng.uniform([r + gap, r + gap], [w - r - gap, h - r - gap])
        if np.all(np.hypot(*(centres - centre).T) >= radii + r + gap):
            return centre, r
    raise ValueError(f"random_workspace: obstacle {k} does not fit in {w:g} x {h:g} m (radius {radius}, gap {gap:g} m)")


VORONOI_PLACES = (0.135, 4.6)
"""Places of :func:`random_voronoi_map`'s roadmaps ≈ a·s² + b·s for a square of side s clearances (measured)."""


def random_voronoi_map(
    rng: np.random.Generator | int | None,
    target_places: int,
    clearance: float = DEFAULT_CLEARANCE,
    name: str = "voronoi",
) -> GraphMap:
    """A Voronoi roadmap of a random workspace with roughly ``target_places`` places (20 to 10,000).

    Lengths scale with ``clearance`` (c): a square workspace whose side s (in c) solves
    :data:`VORONOI_PLACES`, one obstacle per 300 c² (discs of radius 2–6 c, 4 c apart; fewer
    where they do not fit) and a
    sampling spacing of c / 2. While the count is more than 10 % off (at most twice), the
    spacing is rescaled by count / target (the count varies about inversely with it).
    """
    target_places = _count("random_voronoi_map", "target_places", target_places)
    if not _positive(clearance):
        raise ValueError(f"random_voronoi_map: clearance must be a finite number > 0 (m), got {clearance!r}")
    rng = np.random.default_rng(rng)
    a, b = VORONOI_PLACES
    side = (math.sqrt(b * b + 4 * a * target_places) - b) / (2 * a)
    n_obstacles = round(side * side / 300)
    while True:  # a small room may not take every obstacle: one fewer until it does
        try:
            workspace = random_workspace(rng, n_obstacles, side * clearance, (2 * clearance, 6 * clearance), 4 * clearance)
            break
        except ValueError:
            if n_obstacles == 0:
                raise
            n_obstacles -= 1
    spacing = clearance / 2
    graph_map = voronoi_roadmap(workspace, clearance, spacing, name)
    for _ in range(2):
        ratio = len(graph_map.places) / target_places
        if abs(ratio - 1) <= 0.1 or (ratio > 1 and spacing >= clearance):
            break
        spacing = min(spacing * ratio, clearance)
        graph_map = voronoi_roadmap(workspace, clearance, spacing, name)
    return graph_map
