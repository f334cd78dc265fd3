"""experiments/paper003_rendezvous.py: maps, the planner sweep and the episodes, end to end at a tiny size."""

import importlib.util
import json
import math
import sys
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "paper003_rendezvous.py"


@pytest.fixture(scope="module")
def paper003():
    spec = importlib.util.spec_from_file_location("paper003_rendezvous", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # worker processes find its functions by name
    spec.loader.exec_module(module)
    return module


def test_random_grid_is_a_connected_map_with_straight_ways(paper003):
    graph = paper003.random_graph("grid", 200, np.random.default_rng(0))
    assert 150 <= graph.number_of_nodes() <= 250 and nx.is_connected(graph)
    for u, v, data in graph.edges(data=True):
        assert data["length"] == pytest.approx(math.dist(graph.nodes[u]["pos"], graph.nodes[v]["pos"]))
    graph_map = paper003.to_graph_map(graph, "g")
    assert len(graph_map.places) == graph.number_of_nodes() and len(graph_map.ways) == graph.number_of_edges()


def test_size_buckets_and_kinds(paper003):
    assert [paper003.bucket_of(n) for n in (20, 99, 100, 999, 1000, 10_000, 10_050)] == [
        "20-100",
        "20-100",
        "100-1,000",
        "100-1,000",
        "1,000-10,000",
        "1,000-10,000",
        "1,000-10,000",
    ]
    assert paper003.map_kinds() == ("grid", "voronoi")
    sizes = [paper003.log_uniform_size(np.random.default_rng(i), (20, 10_000)) for i in range(200)]
    assert min(sizes) >= 20 and max(sizes) <= 10_000 and np.median(sizes) < 1000


def test_connected_blocking_keeps_the_map_connected(paper003):
    graph = paper003.random_graph("grid", 60, np.random.default_rng(1))
    remaining = graph.copy()
    blocked = paper003._connected_blocking(remaining, list(graph.edges), 10, np.random.default_rng(2))
    assert 0 < len(blocked) <= 10 and nx.is_connected(remaining)
    timed = paper003._timed_blockings(remaining, list(graph.edges), 1.0, 30.0, np.random.default_rng(3))
    assert timed and all(0 <= t <= 30 for *_, t in timed) and nx.is_connected(remaining)
    graph.remove_edges_from(blocked + [w[:2] for w in timed])
    assert nx.is_connected(graph)


def test_planners_subcommand_end_to_end(paper003, tmp_path):
    assert paper003.main(["planners", "--maps", "6", "--places", "20", "300", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "planners.json").read_text())
    assert {"config", "rows", "by_query", "failures", "queries", "wall_s"} <= set(result)
    assert result["failures"] == [] and len(result["queries"]) >= 6
    for row in result["rows"]:
        assert row["bidir-astar-opt optimal"] == 1.0 and row["astar optimal"] == 1.0
        assert 0.0 <= row["bidir-astar suboptimal"] <= 1.0 and row["bidir-astar ratio max"] >= 1.0
    query = result["queries"][0]
    assert set(query) >= {"map", "kind", "places", "query", "optimum"}
    assert set(query["bidir-astar"]) >= {"cost", "ratio", "expansions", "messages", "message_places", "time_ms"}
    text = (tmp_path / "planners.md").read_text()
    assert "bidir-astar-opt optimal" in text and "100.0 %" in text and "FAILURE" not in text


def test_planner_sweep_does_not_depend_on_workers(paper003):
    def strip(queries):
        untimed = [{k: v for k, v in q.items() if not isinstance(v, dict)} for q in queries]
        costs = [{k: v["cost"] for k, v in q.items() if isinstance(v, dict)} for q in queries]
        return untimed, costs

    one = paper003.planner_sweep(maps=3, places=(20, 60), replans=1, workers=1)
    two = paper003.planner_sweep(maps=3, places=(20, 60), replans=1, workers=2)
    assert strip(one["queries"]) == strip(two["queries"])


def test_a_planner_that_misses_the_optimum_is_reported(paper003):
    queries = paper003.planner_sweep(maps=2, places=(20, 40), replans=0)["queries"]
    queries[0]["bidir-astar-opt"]["optimal"] = False
    assert any("bidir-astar-opt" in f for f in paper003.planner_failures(queries))


def test_episodes_subcommand_end_to_end(paper003, tmp_path):
    assert paper003.main(["episodes", "--seeds", "2", "--places", "20", "40", "--out", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "episodes.json").read_text())
    assert {"config", "rows", "by_kind", "failed", "scenarios", "episodes", "wall_s"} <= set(result)
    settings = len(paper003.BLOCKINGS) * len(paper003.THROUGHPUTS)
    assert len(result["rows"]) == settings * len(paper003.EPISODE_POLICIES)
    assert len(result["episodes"]) == 2 * settings * len(paper003.EPISODE_POLICIES)
    for row in result["rows"]:
        keys = {"success", "meeting time / centralized", "worst optimality max", "replans", "messages", "bytes", "expansions"}
        assert keys <= set(row)
        if row["policy"] == "centralized" and row["success"] == 1.0:
            assert row["meeting time / centralized"] == pytest.approx(1.0)
    maps = sorted((tmp_path / "maps").glob("*.json"))
    assert len(maps) == 2 and {s["map"] for s in result["scenarios"]} == {str(p) for p in maps}
    assert "bidir-astar-opt" in (tmp_path / "episodes.md").read_text()
