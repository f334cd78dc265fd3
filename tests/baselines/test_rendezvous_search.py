"""Rendezvous planners of paper 003 (section 4) and the meeting place (section 3, Steps 4 and 8)."""

import importlib.util
import math
import statistics
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from baselines.rendezvous.search import (
    PLANNERS,
    MeetingPlace,
    PlanResult,
    SearchGraph,
    astar,
    bidirectional_astar_optimal,
    centralized_shortest_path,
    distributed_bidirectional_astar,
    meeting_place,
)
from teamgym.maps.graph import load_graph_map

# The random graphs of the planner benchmark (one definition for the benchmark and the tests).
_BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_rendezvous_search.py"
_spec = importlib.util.spec_from_file_location("bench_rendezvous_search", _BENCH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)
grid_map, geometric_map, random_blocked = bench.grid_map, bench.geometric_map, bench.random_blocked

TOL = 1e-9
SEARCHES = [astar, distributed_bidirectional_astar, bidirectional_astar_optimal]

# --------------------------------------------------------------------------- random maps


def random_maps(seed, count):
    rng = np.random.default_rng(seed)
    for i in range(count):
        if i % 3 == 0:
            size = rng.integers(4, 17, size=2)
            yield "grid", *grid_map(rng, *size, rng.uniform(0, 0.3), stretch=float(rng.choice([0.0, 0.5])))
        elif i % 3 == 1:
            yield "grid8", *grid_map(rng, *rng.integers(4, 13, size=2), rng.uniform(0, 0.3), diagonal=True)
        else:
            yield "geometric", *geometric_map(rng, int(rng.integers(15, 150)), rng.uniform(0.1, 0.3), rng.uniform(0, 0.2))


@pytest.fixture(scope="module")
def queries():
    """300 random queries: (kind, graph, blocked, a, b, optimum by networkx, {planner name: result})."""
    rng = np.random.default_rng(1)
    out = []
    for kind, graph, blocked in random_maps(seed=0, count=60):
        open_graph = graph.copy()
        open_graph.remove_edges_from(tuple(way) for way in blocked)
        nodes = list(graph)
        for _ in range(5):
            a, b = (nodes[j] for j in rng.choice(len(nodes), 2))
            try:
                best = nx.shortest_path_length(open_graph, a, b, weight="length")
            except nx.NetworkXNoPath:
                best = math.inf
            results = {f.__name__: f(graph, a, b, blocked) for f in SEARCHES}
            out.append((kind, graph, blocked, a, b, best, results))
    return out


def check_path(graph, blocked, a, b, result):
    """``result.path`` runs from a to b over unblocked ways and ``result.cost`` is its length."""
    path = result.path
    assert path[0] == a and path[-1] == b
    length = 0.0
    for p, q in zip(path, path[1:]):
        assert graph.has_edge(p, q), (p, q)
        assert frozenset((p, q)) not in blocked, (p, q)
        length += graph.edges[p, q]["length"]
    assert result.cost == pytest.approx(length, abs=TOL)
    if result.meeting_node is not None:
        assert result.meeting_node in path


# --------------------------------------------------------------------------- random-map properties


def test_astar_and_optimal_bidirectional_match_networkx(queries):
    unreachable = 0
    for _, graph, blocked, a, b, best, results in queries:
        for name in ("astar", "bidirectional_astar_optimal"):
            result = results[name]
            if math.isinf(best):
                assert result.path is None and math.isinf(result.cost), name
            else:
                assert abs(result.cost - best) <= TOL, (name, a, b, result.cost, best)
                check_path(graph, blocked, a, b, result)
        unreachable += math.isinf(best)
    assert len(queries) >= 200
    assert 5 <= unreachable < len(queries) // 2  # both cases are exercised


def test_distributed_rule_gives_valid_paths_never_shorter_than_optimum(queries):
    ratios = {}
    for kind, graph, blocked, a, b, best, results in queries:
        result = results["distributed_bidirectional_astar"]
        if math.isinf(best):
            assert result.path is None and math.isinf(result.cost)
            continue
        check_path(graph, blocked, a, b, result)
        assert result.cost >= best - TOL
        ratios.setdefault(kind, []).append(result.cost / best if best > 0 else 1.0)
    for kind, values in sorted(ratios.items()):
        worse = [r for r in values if r > 1 + TOL]
        mean, most = statistics.mean(values), max(values)
        print(f"{kind}: paper rule suboptimal on {len(worse)}/{len(values)}, cost ratio mean {mean:.4f} max {most:.4f}")
    assert any(r > 1 + TOL for values in ratios.values() for r in values)  # the paper's rule is not optimal


def test_optimal_bidirectional_expands_no_more_than_astar_on_average(queries):
    found = [r for *_, best, r in queries if not math.isinf(best)]
    mean_astar = statistics.mean(r["astar"].expansions for r in found)
    mean_opt = statistics.mean(r["bidirectional_astar_optimal"].expansions for r in found)
    print(f"mean expansions over {len(found)} queries: A* {mean_astar:.2f}, bidir-astar-opt {mean_opt:.2f}")
    assert mean_opt <= mean_astar


def test_counts_are_consistent(queries):
    for *_, results in queries:
        for name in ("distributed_bidirectional_astar", "bidirectional_astar_optimal"):
            result = results[name]
            first, second = result.expansions_per_agent
            assert result.expansions == first + second
            whole = 0 if result.path is None else 1  # Agent 1's whole-path message
            assert result.messages == second + whole  # Agent 2 sends one path per choice
            assert result.message_places >= result.messages


def test_planners_are_deterministic(queries):
    """Same graph built again (same node and adjacency order), blocked ways in another order: same results."""
    for i, (_, graph, blocked) in enumerate(random_maps(seed=0, count=60)):
        if i % 4:
            continue
        for _, original, _, a, b, _, results in queries[5 * i : 5 * i + 5]:
            assert graph is not original
            for planner in SEARCHES:
                assert planner(graph, a, b, sorted(blocked, key=sorted, reverse=True)) == results[planner.__name__]
            assert astar(SearchGraph(graph), a, b, blocked) == results["astar"]


# --------------------------------------------------------------------------- hand-made cases


def make_graph(places, ways):
    graph = nx.Graph()
    for name, pos in places.items():
        graph.add_node(name, pos=pos)
    for u, v, *length in ways:
        graph.add_edge(u, v, length=length[0] if length else math.dist(places[u], places[v]))
    return graph


@pytest.fixture
def line():
    return make_graph({i: (float(i), 0.0) for i in range(5)}, [(i, i + 1) for i in range(4)])


@pytest.fixture
def detour():
    """a-m-b is 4.8 long and looks shortest by the heuristic (f = 4.4); a-c-b is 2 sqrt(5) ~ 4.472."""
    places = {"a": (0.0, 0.0), "m": (2.0, 0.0), "c": (2.0, 1.0), "b": (4.0, 0.0)}
    return make_graph(places, [("a", "m", 2.4), ("m", "b", 2.4), ("a", "c"), ("c", "b")])


def test_paper_protocol_on_a_line_counts_messages(line):
    result = distributed_bidirectional_astar(line, 0, 4)
    # Agent 2 sends [4], [4, 3], [4, 3, 2]; Agent 1 chooses 0, 1, then 2, which is on [4, 3, 2].
    assert result == PlanResult([0, 1, 2, 3, 4], 4.0, 6, (3, 3), 2, 4, 1 + 2 + 3 + 5)


def test_paper_rule_stops_at_a_suboptimal_meeting(detour):
    result = distributed_bidirectional_astar(detour, "a", "b")
    # Both agents choose m second (f = 4.4 < 4.472); m is on Agent 2's path [b, m].
    assert result.path == ["a", "m", "b"] and result.cost == pytest.approx(4.8)
    assert (result.meeting_node, result.expansions_per_agent, result.messages, result.message_places) == ("m", (2, 2), 3, 6)
    for planner in (astar, bidirectional_astar_optimal, centralized_shortest_path):
        assert planner(detour, "a", "b").path == ["a", "c", "b"]
    assert bidirectional_astar_optimal(detour, "a", "b").meeting_node == "c"


def test_astar_breaks_ties_by_smaller_h_then_node_order():
    places = {"s": (0.0, 0.0), "p": (1.0, 0.0), "q": (0.0, 1.0), "t": (1.0, 1.0)}
    ways = [("s", "p"), ("s", "q"), ("p", "t"), ("q", "t")]
    assert astar(make_graph(places, ways), "s", "t").path == ["s", "p", "t"]  # p comes first in the node order
    reordered = {k: places[k] for k in ("s", "q", "p", "t")}
    assert astar(make_graph(reordered, ways), "s", "t").path == ["s", "q", "t"]
    # Equal f = 2 at u (g 1, h 1) and at t (g 2, h 0): t, the smaller h, is taken first though u comes first in order.
    graph = make_graph({"s": (0.0, 0.0), "u": (1.0, 0.0), "t": (2.0, 0.0)}, [("s", "t"), ("s", "u")])
    assert astar(graph, "s", "t").expansions == 2


@pytest.mark.parametrize("planner", list(PLANNERS.values()))
def test_same_place_and_unreachable(planner, line):
    assert planner(line, 2, 2).path == [2] and planner(line, 2, 2).cost == 0.0
    result = planner(line, 0, 4, [(2, 3)])
    assert result.path is None and math.isinf(result.cost) and not result.found and result.meeting_node is None
    line.add_node("island", pos=(9.0, 9.0))
    assert planner(line, "island", 0).path is None
    assert planner(line, 0, "island").path is None


@pytest.mark.parametrize("planner", list(PLANNERS.values()))
def test_graph_map_and_blocked_way_forms(planner):
    graph_map = load_graph_map("square4")
    graph, diagonal = graph_map.to_networkx(), graph_map.way("A", "C")
    for blocked in ([], [diagonal], [diagonal.ends], [("C", "A"), ("D", "A")]):
        pairs = [tuple(way) if isinstance(way, frozenset) else way for way in blocked]
        result = planner(graph, "A", "C", iter(blocked))
        assert result.cost == pytest.approx(graph_map.shortest_path_length("A", "C", blocked=pairs))
        assert result.path == graph_map.shortest_path("A", "C", blocked=pairs)


def test_bad_input_is_named(line):
    with pytest.raises(KeyError, match="'nowhere'"):
        astar(line, 0, "nowhere")
    with pytest.raises(KeyError, match="no way between 0 and 2"):
        bidirectional_astar_optimal(line, 0, 4, [(0, 2)])
    with pytest.raises(KeyError, match="no place 7"):
        distributed_bidirectional_astar(line, 0, 4, [(0, 7)])
    with pytest.raises(TypeError, match="two ends"):
        astar(line, 0, 4, [(0, 1, 2)])
    with pytest.raises(KeyError, match="no way between 0 and 2"):
        centralized_shortest_path(line, 0, 4, [(0, 2)])
    with pytest.raises(ValueError, match="shorter than the straight line"):
        astar(make_graph({0: (0.0, 0.0), 1: (1.0, 0.0)}, [(0, 1, 0.5)]), 0, 1)
    no_pos = nx.path_graph(2)
    nx.set_edge_attributes(no_pos, 1.0, "length")
    with pytest.raises(KeyError, match="'pos'"):
        astar(no_pos, 0, 1)
    with pytest.raises(TypeError, match="undirected"):
        astar(nx.DiGraph(line), 0, 4)


def test_search_graph_cache(line):
    prepared = SearchGraph.of(line)
    assert SearchGraph.of(line) is prepared and SearchGraph.of(prepared) is prepared
    assert astar(prepared, 0, 4) == astar(line, 0, 4)
    line.add_node(9, pos=(9.0, 0.0))
    assert SearchGraph.of(line) is not prepared  # a changed node count rebuilds
    line.edges[0, 1]["length"] = 3.0
    assert astar(line, 0, 4).cost == 4.0  # edited in place: the cache is stale until refreshed
    SearchGraph.of(line, refresh=True)
    assert astar(line, 0, 4).cost == 6.0


# --------------------------------------------------------------------------- meeting place


def test_meeting_place_equal_speeds_is_the_node_nearest_the_middle():
    place = meeting_place("abcd", (1.0, 1.0), lengths=[1.0, 1.0, 3.0])  # total 5: middle at 2.5
    assert (place.node, place.index, place.time) == ("c", 2, 3.0)
    assert place.way == ("c", "d") and place.fraction == pytest.approx(0.5 / 3) and place.way_time == 2.5


@pytest.mark.parametrize(("speeds", "index", "covered_by_b"), [((2.0, 1.0), 2, 1.0), ((1.0, 2.0), 1, 2.0)])
def test_meeting_place_speed_ratio_two_the_slow_robot_covers_a_third(speeds, index, covered_by_b):
    place = meeting_place("abcd", speeds, lengths=[1.0, 1.0, 1.0])
    assert place.index == index and place.way is None and place.fraction == 0.0
    assert 3.0 - place.distance_a == pytest.approx(covered_by_b)
    assert place.time == place.way_time == pytest.approx(1.0)


def test_meeting_place_on_a_way_and_ties():
    place = meeting_place(["a", "b", "c"], (2.0, 1.0), lengths=[1.0, 1.0])
    # Continuous meeting after 4/3 m of A's travel, a third into way b-c; nodes b and c tie (time 1 s): b, nearer A.
    assert place == MeetingPlace("b", 1, 1.0, ("b", "c"), pytest.approx(1 / 3), pytest.approx(2 / 3), pytest.approx(4 / 3))
    assert meeting_place(["a"], (1.0, 1.0), lengths=[]) == MeetingPlace("a", 0, 0.0, None, 0.0, 0.0, 0.0)
    assert meeting_place(["a", "b"], (1.0, 0.0), lengths=[2.0]).node == "b"  # B stands still


def test_meeting_place_is_the_minimax_node_on_random_paths():
    rng = np.random.default_rng(3)
    for _ in range(200):
        lengths = list(rng.uniform(0.1, 3.0, size=int(rng.integers(1, 9))))
        va, vb = rng.uniform(0.2, 2.0, size=2)
        vb = va if rng.random() < 0.5 else vb
        place = meeting_place(range(len(lengths) + 1), (va, vb), lengths=lengths)
        cum = np.concatenate([[0.0], np.cumsum(lengths)])
        times = np.maximum(cum / va, (cum[-1] - cum) / vb)
        assert place.time == pytest.approx(times.min()) and place.index == int(np.argmin(times))
        assert place.way_time <= place.time + TOL
        if va == vb:
            assert place.index == int(np.argmin(np.abs(cum - cum[-1] / 2)))


def test_meeting_place_length_sources_agree(detour):
    path = ["a", "c", "b"]
    positions = {k: detour.nodes[k]["pos"] for k in detour}
    by_graph = meeting_place(path, (1.0, 3.0), graph=detour)
    assert by_graph == meeting_place(path, (1.0, 3.0), positions=positions)
    assert by_graph == meeting_place(path, (1.0, 3.0), lengths=[math.sqrt(5)] * 2)


def test_meeting_place_bad_input(detour):
    with pytest.raises(ValueError, match="speeds"):
        meeting_place(["a", "c"], (0.0, 0.0), graph=detour)
    with pytest.raises(ValueError, match="speeds"):
        meeting_place(["a", "c"], (-1.0, 1.0), graph=detour)
    with pytest.raises(TypeError, match="exactly one"):
        meeting_place(["a", "c"], graph=detour, lengths=[1.0])
    with pytest.raises(ValueError, match="empty"):
        meeting_place([], lengths=[])
    with pytest.raises(KeyError, match="no way between 'a' and 'b'"):
        meeting_place(["a", "b"], graph=detour)
    with pytest.raises(ValueError, match="need 2 way lengths"):
        meeting_place("abc", lengths=[1.0])
