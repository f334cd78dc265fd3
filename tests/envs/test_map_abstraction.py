"""Map abstractions of paper 003, section 2: cell decomposition, Voronoi roadmap, random maps."""

import math

import networkx as nx
import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon, box

from teamgym.maps import (
    Workspace,
    cell_decomposition,
    random_grid_map,
    random_voronoi_map,
    random_workspace,
    triangulate_free_space,
    validate_graph_map,
    voronoi_roadmap,
)

L_SHAPE = ((6.0, 1.0), (9.0, 1.0), (9.0, 2.0), (7.0, 2.0), (7.0, 4.0), (6.0, 4.0))  # simple, not convex


@pytest.fixture
def workspace():
    """10 x 6 m: a triangle, a square, a non-convex L and a block in a corner (touching two walls)."""
    return Workspace(
        10.0,
        6.0,
        (
            ((2.0, 2.0), (4.0, 2.0), (3.0, 4.0)),
            ((1.0, 4.5), (2.0, 4.5), (2.0, 5.5), (1.0, 5.5)),
            L_SHAPE,
            ((9, 5), (10, 5), (10, 6), (9, 6)),
        ),
    )


def test_workspace_free_space_and_checks(workspace):
    assert workspace.size == (10.0, 6.0)
    assert workspace.free_space.area == pytest.approx(60 - 2 - 1 - 5 - 1)
    with pytest.raises(ValueError, match="width"):
        Workspace(0, 1)
    with pytest.raises(ValueError, match="obstacle 0: needs at least 3"):
        Workspace(1, 1, (((0, 0), (1, 1)),))
    with pytest.raises(ValueError, match="obstacle 0 is not a simple polygon"):
        Workspace(4, 4, (((0, 0), (2, 2), (2, 0), (0, 2)),))  # a bow tie
    with pytest.raises(TypeError, match="obstacle 0"):
        Workspace(4, 4, ((1, 2, 3),))


# -- cell decomposition ----------------------------------------------------------------------


def test_triangulation_covers_the_free_area_and_never_crosses_an_obstacle(workspace):
    triangles = triangulate_free_space(workspace)
    free = workspace.free_space
    assert all(len(shapely.get_coordinates(t)) == 4 and t.area > 0 for t in triangles)
    assert sum(t.area for t in triangles) == pytest.approx(free.area, rel=1e-12)
    union = shapely.union_all(triangles)
    assert union.symmetric_difference(free).area < 1e-9  # no gaps, and (areas equal) no overlaps
    for t in triangles:
        assert t.intersection(workspace.obstacle_region).area < 1e-12
        assert box(0, 0, 10, 6).covers(t)


def test_cell_decomposition_places_are_centroids_and_ways_shared_edges(workspace):
    triangles = triangulate_free_space(workspace)
    graph_map = validate_graph_map(cell_decomposition(workspace))
    assert len(graph_map.places) == len(triangles) and not graph_map.allow_disconnected
    for p, t in zip(graph_map.places, triangles):
        assert p.pos == pytest.approx((t.centroid.x, t.centroid.y))
    for w in graph_map.ways:
        edge = triangles[int(w.a)].intersection(triangles[int(w.b)])
        assert edge.geom_type == "LineString" and edge.length == pytest.approx(w.width)
        assert w.length == pytest.approx(math.dist(graph_map.place(w.a).pos, graph_map.place(w.b).pos))
    outline = sum(1 for t in triangles for e in _edges(t) if not any(o.boundary.covers(e) for o in triangles if o is not t))
    assert 2 * len(graph_map.ways) + outline == 3 * len(triangles)  # every inner edge is a way
    assert nx.is_connected(graph_map.to_networkx())


def _edges(triangle):
    xy = shapely.get_coordinates(triangle)
    return [shapely.LineString(xy[k : k + 2]) for k in range(3)]


def test_cell_decomposition_of_a_split_workspace_allows_disconnection():
    split = Workspace(6.0, 4.0, (((2.0, -1.0), (3.0, -1.0), (3.0, 5.0), (2.0, 5.0)),))  # a wall across, past both walls
    graph_map = validate_graph_map(cell_decomposition(split))
    assert graph_map.allow_disconnected and nx.number_connected_components(graph_map.to_networkx()) == 2
    assert sum(t.area for t in triangulate_free_space(split)) == pytest.approx(20.0)
    with pytest.raises(ValueError, match="cover the whole"):
        cell_decomposition(Workspace(1.0, 1.0, (((-1, -1), (2, -1), (2, 2), (-1, 2)),)))


# -- Voronoi roadmap -------------------------------------------------------------------------


def test_voronoi_ways_keep_the_clearance(workspace):
    clearance = 0.3
    graph_map = validate_graph_map(voronoi_roadmap(workspace, clearance))
    walls = box(0, 0, workspace.width, workspace.height).exterior
    for w in graph_map.ways:
        segment = shapely.LineString([graph_map.place(w.a).pos, graph_map.place(w.b).pos])
        gap = min(segment.distance(workspace.obstacle_region), segment.distance(walls))
        assert gap >= clearance - 1e-9
        assert w.width == pytest.approx(2 * gap, abs=1e-9)
        assert workspace.free_space.contains(segment)
        assert w.length == pytest.approx(segment.length)
    assert nx.is_connected(graph_map.to_networkx()) and not graph_map.allow_disconnected


def test_voronoi_roadmap_loops_round_the_obstacles_with_room_around(workspace):
    graph_map = voronoi_roadmap(workspace, 0.3)
    graph = graph_map.to_networkx()
    # loops round the triangle and the L; the square is 0.5 m from the top wall, less than 2 x 0.3 m
    assert graph.number_of_edges() - graph.number_of_nodes() + 1 == 2
    xs = [p.x for p in graph_map.places]
    assert min(xs) < 1.0 and max(xs) > 9.0  # spans the room


def test_voronoi_merges_near_duplicates_and_drops_narrow_passages(workspace):
    spacing = 0.1
    graph_map = voronoi_roadmap(workspace, 0.3, spacing=spacing)
    xy = np.array([p.pos for p in graph_map.places])
    gaps = np.linalg.norm(xy[:, None] - xy[None], axis=2) + np.eye(len(xy)) * 1e9
    assert gaps.min() >= spacing / 4
    narrow = Workspace(4.0, 1.0)  # the widest free circle has radius 0.5
    assert voronoi_roadmap(narrow, 0.45).places
    with pytest.raises(ValueError, match="no Voronoi segment keeps clearance 0.6"):
        voronoi_roadmap(narrow, 0.6)
    with pytest.raises(ValueError, match="clearance"):
        voronoi_roadmap(narrow, -1.0)


def test_voronoi_keeps_the_largest_part_only():
    """A thin wall with a gap narrower than the clearance: only the larger room's roadmap remains."""
    rooms = Workspace(6.0, 3.0, (((2.0, 0.0), (2.1, 0.0), (2.1, 2.8), (2.0, 2.8)),))
    graph_map = validate_graph_map(voronoi_roadmap(rooms, 0.3))
    assert all(p.x > 2.1 for p in graph_map.places)


# -- random maps -----------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 7, 20, 101])
def test_random_grid_map_size_and_connectivity(n):
    graph_map = validate_graph_map(random_grid_map(n, np.random.default_rng(n), drop=0.3, diagonals=0.5))
    assert len(graph_map.places) == n
    for w in graph_map.ways:
        assert w.length in (1.0, pytest.approx(math.sqrt(2)))


def test_random_grid_map_drops_ways_off_a_spanning_tree():
    full = random_grid_map(100, 0, drop=0.0)
    assert len(full.ways) == 2 * 10 * 9
    dropped = random_grid_map(100, 0, drop=0.2)
    assert len(dropped.ways) == 180 - 36 and nx.is_connected(dropped.to_networkx())
    tree = random_grid_map(100, 0, drop=1.0)
    assert len(tree.ways) == 99 and nx.is_tree(tree.to_networkx())
    with pytest.raises(ValueError, match="drop"):
        random_grid_map(10, 0, drop=1.5)
    with pytest.raises(ValueError, match="n_places"):
        random_grid_map(0, 0)


def test_random_maps_are_deterministic_with_a_seeded_rng():
    assert random_grid_map(50, np.random.default_rng(3), diagonals=0.3) == random_grid_map(
        50, np.random.default_rng(3), diagonals=0.3
    )
    assert random_grid_map(50, 3, diagonals=0.3) != random_grid_map(50, 4, diagonals=0.3)
    assert random_workspace(np.random.default_rng(5), 6) == random_workspace(np.random.default_rng(5), 6)
    assert (
        random_voronoi_map(np.random.default_rng(7), 200).to_dict() == random_voronoi_map(np.random.default_rng(7), 200).to_dict()
    )
    assert random_voronoi_map(7, 200).to_dict() != random_voronoi_map(8, 200).to_dict()


def test_random_workspace_keeps_obstacles_apart():
    ws = random_workspace(np.random.default_rng(1), 12, (10.0, 8.0), radius=(0.3, 0.8), gap=0.5)
    assert ws.size == (10.0, 8.0) and len(ws.obstacles) == 12
    polygons = [Polygon(o) for o in ws.obstacles]
    for i, p in enumerate(polygons):
        assert 3 <= len(ws.obstacles[i]) <= 7 and p.convex_hull.equals(p)
        assert box(0.5, 0.5, 9.5, 7.5).contains(p)
        assert all(p.distance(q) >= 0.5 for q in polygons[i + 1 :])
    with pytest.raises(ValueError, match="does not fit"):
        random_workspace(0, 50, 3.0)
    for bad in ({"radius": (1.0, 0.5)}, {"gap": -1.0}, {"size": (4.0, 0.0)}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            random_workspace(0, 1, **bad)


@pytest.mark.parametrize("target", [20, 100, 1000])
def test_random_voronoi_map_has_roughly_the_requested_places(target):
    graph_map = validate_graph_map(random_voronoi_map(np.random.default_rng(target), target))
    assert 0.8 * target <= len(graph_map.places) <= 1.2 * target


def test_a_10000_place_grid_map_is_built_and_valid():
    graph_map = validate_graph_map(random_grid_map(10_000, np.random.default_rng(0), diagonals=0.2))
    assert len(graph_map.places) == 10_000


def test_a_10000_place_voronoi_map_is_built_and_valid():
    graph_map = validate_graph_map(random_voronoi_map(np.random.default_rng(0), 10_000))
    assert 8_000 <= len(graph_map.places) <= 12_000
