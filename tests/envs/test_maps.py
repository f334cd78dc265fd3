"""Office maps (paper 000, section 2.1): loading, validation, walls, topology and costs (eqs. 2-4)."""

import copy
import json
import math

import networkx as nx
import numpy as np
import pytest

from teamgym.maps import (
    ClutterEstimate,
    MapError,
    TopologicalModel,
    available_maps,
    door_cost,
    load_map,
    map_from_dict,
    passage_cost,
    wall_layout,
)
from teamgym.sim.geometry import point_in_convex

PAPER_CLUTTER = [0.7, 0, 0.1, 0.6, 0, 0, 0, 0, 0.2, 0, 0.3, 0.2]
TABLE1_DOORS = {"D3,4", "D9,10", "D1,2_1", "D1,2_2", "D2,3", "D10,11", "D1,8", "D11,12", "D3,6"}


def two_rooms(**changes):
    """A valid 2-room map (mm) with one door; ``changes`` overwrite top-level keys."""
    data = {
        "name": "two",
        "size": [800, 400],
        "sectors": [
            {"id": "A", "top_left": [0, 400], "bottom_right": [400, 0], "clutter": 0.2},
            {"id": "B", "top_left": [400, 400], "bottom_right": [800, 0], "clutter": 0.0},
        ],
        "doors": [{"id": "D", "centre": [400, 200], "radius": 70, "width": 110}],
        "furniture": [{"sector": "A", "rect": [20, 20, 100, 100]}],
    }
    data.update(changes)
    return data


# -- shipped maps ------------------------------------------------------------------------


def test_shipped_maps_are_listed_and_valid():
    assert {"office12", "lab7"} <= set(available_maps())
    for name in available_maps():
        office = load_map(name)
        assert office.name == name


def test_office12_matches_the_paper():
    office = load_map("office12")
    assert office.size == pytest.approx((1.5, 1.0))
    assert office.sector_ids == [f"S{i}" for i in range(1, 13)]
    assert [s.clutter for s in office.sectors] == PAPER_CLUTTER
    assert len(office.doors) == 13
    assert set(office.door_ids) >= TABLE1_DOORS
    assert {d.id: d.open_probability for d in office.doors if d.open_probability != 1.0} == {"D3,6": 0.2}
    assert office.door_ids.index("D3,6") == 4  # o_5 in the paper
    corridor = {s.id for s in office.sectors if s.kind == "corridor"}
    assert corridor == {"S5", "S6", "S7", "S8"}
    graph = TopologicalModel(office).graph
    for a, b in [("S5", "S6"), ("S6", "S7"), ("S7", "S8")]:
        assert graph.has_edge(a, b)  # corridor parts joined without doors
    for door in office.doors:
        assert graph.degree(door.id) == 2
    # every sector stays reachable with D3,6 closed
    graph.remove_node("D3,6")
    assert nx.is_connected(graph)


def test_lab7_matches_section_5_4():
    office = load_map("lab7")
    assert office.size == pytest.approx((1.2, 1.3))
    assert len(office.sectors) == 7 and len(office.doors) == 6
    s6 = office.sector("S6")
    assert s6.contains(0.05, 0.65) and s6.contains(0.6, 0.35)  # the point-to-point run of section 5.2


def test_furniture_in_proportion_to_clutter():
    office = load_map("office12")
    covered = {s.id: 0.0 for s in office.sectors}
    for f in office.furniture:
        xs, ys = zip(*f.vertices)
        covered[f.sector] += (max(xs) - min(xs)) * (max(ys) - min(ys)) / office.sector(f.sector).area
    for s in office.sectors:
        if s.clutter == 0:
            assert covered[s.id] == 0
    ranked = sorted(office.sectors, key=lambda s: s.clutter)
    fractions = [covered[s.id] for s in ranked]
    assert fractions[-1] == max(fractions)  # the most cluttered room has the most furniture


def test_walls_leave_door_openings_and_passages_free():
    office = load_map("office12")
    walls, doors = wall_layout(office)
    assert [d.name for d in doors] == office.door_ids
    half = office.wall_thickness / 2

    def blocked(p):
        for w in walls:
            (ax, ay), (bx, by) = w.a, w.b
            t = max(0.0, min(1.0, ((p[0] - ax) * (bx - ax) + (p[1] - ay) * (by - ay)) / ((bx - ax) ** 2 + (by - ay) ** 2)))
            if math.hypot(p[0] - ax - t * (bx - ax), p[1] - ay - t * (by - ay)) < half + 1e-9:
                return True
        return False

    for door in office.doors:
        assert not blocked(door.centre), door.id
    for a, b in office.passages:
        sa, sb = office.sector(a), office.sector(b)
        x = sa.x_max if abs(sa.x_max - sb.x_min) < 1e-9 else sa.x_min
        assert not blocked((x, (sa.y_min + sa.y_max) / 2))
    # a point on a plain wall between two rooms is blocked
    assert blocked((0.375, 0.8))
    # and the outer boundary is closed
    assert blocked((0.0, 0.5)) and blocked((0.7, 1.0))


# -- validation ---------------------------------------------------------------------------


def test_valid_small_map_and_inferred_door_sectors():
    office = map_from_dict(two_rooms())
    assert office.door("D").sectors == ("A", "B")
    assert office.door("D").width == pytest.approx(0.11)


@pytest.mark.parametrize(
    ("mutate", "fragment"),
    [
        (lambda d: d["sectors"][1].update(top_left=[300, 400]), "overlap"),
        (lambda d: d["doors"][0].update(centre=[200, 200]), "touches no sector"),
        (lambda d: d["doors"][0].update(centre=[0, 200], sectors=["A", "B"]), "touches only sector 'A'"),
        (lambda d: d["doors"][0].update(centre=[400, 400]), "does not fit"),
        (lambda d: d["doors"].clear(), "disconnected"),
        (lambda d: d["doors"][0].update(open_probability=0.5), "always_connected"),
        (lambda d: d["sectors"][0].update(clutter=1.0), "clutter"),
        (lambda d: d["sectors"][0].update(top_left=[400, 400], bottom_right=[0, 0]), "top_left"),
        (lambda d: d["sectors"][0].update(centre=[600, 100]), "centre point"),
        (lambda d: d["doors"][0].update(width=500, radius=300), "does not fit"),
        (lambda d: d["doors"][0].update(radius=40), "radius"),
        (lambda d: d["doors"][0].update(sectors=["A", "Z"]), "unknown sector 'Z'"),
        (lambda d: d["furniture"].append({"sector": "A", "rect": [350, 150, 390, 250]}), "circle of door"),
        (lambda d: d["furniture"].append({"sector": "B", "rect": [20, 20, 100, 100]}), "leaves its sector"),
        (
            lambda d: d["furniture"].append(
                {"sector": "A", "polygon": [[150, 20], [250, 20], [200, 60], [250, 120], [150, 120]]}
            ),
            "convex",
        ),
        (lambda d: d["furniture"].append({"sector": "A", "rect": [150, 150, 250, 250]}), "centre point"),
        (lambda d: d["furniture"].append({"sector": "A", "rect": [50, 50, 150, 150]}), "overlap"),
        (lambda d: d.update(passages=[["A", "B"]]), "open passage"),
        (lambda d: d.update(passages=[["A", "A"]]), "passage"),
        (lambda d: d.update(colour="red"), "unknown key"),
        (lambda d: d.update(units="inch"), "units"),
        (lambda d: d["sectors"][0].update(clutter="high"), "finite number"),
        (lambda d: d["sectors"].append({"id": "A", "top_left": [800, 400], "bottom_right": [900, 0], "clutter": 0}), "duplicate"),
        (lambda d: d.update(size=[700, 400]), "outside"),
    ],
)
def test_broken_maps_are_rejected_with_a_clear_message(mutate, fragment):
    data = two_rooms()
    mutate(data)
    with pytest.raises(MapError, match=fragment):
        map_from_dict(data, source="broken.json")


def test_uncertain_door_allowed_when_map_says_so():
    data = two_rooms(always_connected=False)
    data["doors"][0]["open_probability"] = 0.5
    assert map_from_dict(data).door("D").open_probability == 0.5


def test_disconnected_message_names_the_stranded_sectors():
    data = two_rooms()
    data["sectors"].append({"id": "C", "top_left": [0, 900], "bottom_right": [100, 800], "clutter": 0})
    data["size"] = [800, 900]
    with pytest.raises(MapError, match=r"\['C'\]"):
        map_from_dict(data)


def test_load_map_errors(tmp_path):
    with pytest.raises(MapError, match="no map 'nowhere'"):
        load_map("nowhere")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(MapError, match="not valid JSON"):
        load_map(bad)
    good = tmp_path / "good.json"
    good.write_text(json.dumps(two_rooms()))
    assert load_map(good).sector_ids == ["A", "B"]


def test_units_are_converted():
    data = two_rooms(units="m", size=[0.8, 0.4], wall_thickness=0.01)
    for s in data["sectors"]:
        s["top_left"] = [v / 1000 for v in s["top_left"]]
        s["bottom_right"] = [v / 1000 for v in s["bottom_right"]]
    data["doors"][0].update(centre=[0.4, 0.2], radius=0.07, width=0.11)
    data["furniture"][0]["rect"] = [0.02, 0.02, 0.1, 0.1]
    assert map_from_dict(copy.deepcopy(data)) == map_from_dict(two_rooms())


def test_point_in_convex():
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    assert point_in_convex(square, (0.5, 0.5)) and not point_in_convex(square, (1.5, 0.5))


# -- topology and costs (eqs. 2-4) -------------------------------------------------------------


def test_cost_reading_of_eq3():
    # grows with L and with clutter, grows as o falls, infinite for a closed door
    assert door_cost(0.2, 0.0, 1.0) == pytest.approx(0.2)
    assert door_cost(0.4, 0.0, 1.0) > door_cost(0.2, 0.0, 1.0)
    assert door_cost(0.2, 0.5, 1.0) == pytest.approx(0.4)
    assert door_cost(0.2, 0.0, 0.2) == pytest.approx(1.0)
    assert door_cost(0.2, 0.0, 0.0) == math.inf
    assert door_cost(0.2, 1.0, 1.0) == math.inf
    assert passage_cost(0.4, 0.0, 0.0) == pytest.approx(0.4)
    assert passage_cost(0.4, 0.5, 0.0) == pytest.approx(0.2 * 2 + 0.2)


def test_return_trip_reading_of_eq3():
    """Every failed attempt also costs the way back: L (2 − o) / ((1 − c) o), equal to per-attempt at o = 1."""
    for length, clutter in [(0.2, 0.0), (0.3, 0.6)]:
        assert door_cost(length, clutter, 1.0, "return-trip") == pytest.approx(door_cost(length, clutter, 1.0))
    assert door_cost(0.2, 0.0, 0.2, "return-trip") == pytest.approx(0.2 * 9)  # D3,6: 9 L against 5 L
    assert door_cost(0.2, 0.5, 0.5, "return-trip") == pytest.approx(0.2 * 1.5 / 0.25)
    assert door_cost(0.2, 0.0, 0.0, "return-trip") == math.inf
    with pytest.raises(ValueError, match="door_reading must be one of"):
        door_cost(0.2, 0.0, 1.0, "squared")
    with pytest.raises(ValueError, match="door_reading must be one of"):
        TopologicalModel(load_map("office12"), door_reading="squared")
    office = load_map("office12")
    default, trips = TopologicalModel(office), TopologicalModel(office, door_reading="return-trip")
    changed = ~np.isclose(default.cost_matrix(), trips.cost_matrix()) & np.isfinite(default.cost_matrix())
    d36 = default.index["D3,6"]
    assert {tuple(sorted((a, b))) for a, b in zip(*np.nonzero(changed))} == {
        (default.index["S3"], d36),
        (default.index["S6"], d36),
    }
    assert trips.cost(default.index["S3"], d36) == pytest.approx(9 / 5 * default.cost(default.index["S3"], d36))


def test_office12_table1_rebuilt_for_table_1():
    """No door of S9-S11 onto the corridor; the unnamed doors join S12 to S8; the rest as office12."""
    rebuilt, office = load_map("office12-table1"), load_map("office12")
    assert rebuilt.sector_ids == office.sector_ids and rebuilt.size == office.size
    assert [s.clutter for s in rebuilt.sectors] == PAPER_CLUTTER
    assert set(rebuilt.door_ids) == TABLE1_DOORS | {"D8,12_1", "D8,12_2"}
    assert rebuilt.door_ids.index("D3,6") == 4  # o_5 in the paper
    assert {d.id: d.open_probability for d in rebuilt.doors if d.open_probability != 1.0} == {"D3,6": 0.2}
    corridor = {"S5", "S6", "S7", "S8"}
    for door in rebuilt.doors:
        if {"S9", "S10", "S11"} & set(door.sectors):
            assert not corridor & set(door.sectors), door.id
    assert [f.id for f in rebuilt.furniture] == [f.id for f in office.furniture]
    named = {d.id: d for d in office.doors}
    for door in rebuilt.doors:
        if door.id in named:
            assert door == named[door.id]
    graph = TopologicalModel(rebuilt).graph
    graph.remove_node("D3,6")
    assert nx.is_connected(graph)  # every sector stays reachable with D3,6 closed


def test_topological_model_costs_and_paths():
    office = load_map("office12")
    model = TopologicalModel(office)
    i = model.index
    s3, d36, s6 = i["S3"], i["D3,6"], i["S6"]
    length = math.dist(office.sector("S3").centre, office.door("D3,6").centre)  # eq. (4)
    assert model.cost(s3, d36) == pytest.approx(length / ((1 - 0.1) * 0.2))
    assert model.cost(s3, s6) == math.inf  # not adjacent
    costs = model.path_costs()
    assert np.allclose(costs, costs.T) and np.all(np.diag(costs) == 0)
    assert model.shortest_path("S3", "S6") == ["S3", "D3,6", "S6"]
    uncertain = costs[s3, s6]
    model.door_open[office.door_ids.index("D3,6")] = 1.0
    assert model.path_costs()[s3, s6] == pytest.approx(uncertain * 0.2)  # 1/o_j on both door edges
    model.door_open[office.door_ids.index("D3,6")] = 0.0
    path = model.shortest_path("S3", "S6")  # known closed: the long way round
    assert path[0] == "S3" and path[-1] == "S6" and "D3,6" not in path and "S1" in path
    assert model.cost(s3, d36) == math.inf
    graph = model.weighted_graph()
    assert not graph.has_edge("S3", "D3,6") and graph.has_edge("S6", "S7")
    # the matrix agrees with networkx's Dijkstra on the weighted graph
    lengths = dict(nx.all_pairs_dijkstra_path_length(graph, weight="weight"))
    costs = model.path_costs()
    for u in ("S1", "S4", "S9", "D7,11"):
        for v in ("S5", "S12", "D2,3"):
            assert costs[i[u], i[v]] == pytest.approx(lengths[u][v])


def test_clutter_estimate_eq2():
    estimate = ClutterEstimate(np.array([0.0, 0.5]), prior_weight=1.0)
    assert estimate.values == pytest.approx([0.0, 0.5])
    estimate.observe(0, straight=1.0, travelled=2.0)  # ratio 0.5
    assert estimate.values[0] == pytest.approx(1 - (1.0 + 0.5) / 2)
    for _ in range(1000):
        estimate.observe(1, straight=1.0, travelled=1.0)  # an empty sector after all
    assert estimate.values[1] == pytest.approx(0.0, abs=1e-3)
    estimate.observe(1, straight=0.0, travelled=1.0)  # degenerate tasks are ignored
    assert estimate.count[1] == 1000
    with pytest.raises(ValueError, match="prior_weight"):
        ClutterEstimate(np.zeros(2), prior_weight=0)
