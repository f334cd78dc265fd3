"""Rendezvous planners of paper 003 (``baselines.rendezvous.search``): quality, expansions and speed.

Part 1, random queries (5 per map) on three kinds of random maps with random blocked ways:
``grid`` (4-connected, 6-24 places a side, up to 30 % of the ways blocked, half of the maps with
lengths stretched up to 1.5x the straight line), ``grid8`` (8-connected, 6-19 a side) and
``geometric`` (random geometric graphs, 30-300 places, Euclidean lengths, up to 20 % blocked).
Per kind: unreachable queries, mismatches of ``astar`` and ``bidir-astar-opt`` against
networkx (must be 0), how often and by how much the paper's stopping rule (``bidir-astar``)
is suboptimal (cost / optimum), mean expansions and messages.

Part 2, time per query of ``bidir-astar-opt`` beside ``networkx.astar_path`` (Euclidean
heuristic, weight ``length``) on a ~40-place (8 x 5) and a 10,000-place (100 x 100) grid with
10 % of the ways blocked. networkx gets the graph with the blocked ways removed beforehand
(untimed, its best case); our planners get the whole graph and the blocked set per query
(resolving it is timed; the ``SearchGraph`` is prepared once, like networkx's graph). Each
query is timed ``--repeat`` times (best kept); the table shows the mean over ``--queries``
random connected queries and the ratio to networkx (target: within 3x).

    python benchmarks/bench_rendezvous_search.py [--maps 200] [--queries 20] [--repeat 5] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import timeit
from collections import defaultdict

import networkx as nx
import numpy as np

from baselines.rendezvous.search import (
    SearchGraph,
    astar,
    bidirectional_astar_optimal,
    distributed_bidirectional_astar,
)

TOL = 1e-9
KINDS = ("grid", "grid8", "geometric")


def random_blocked(rng: np.random.Generator, graph: nx.Graph, p_block: float) -> set[frozenset]:
    edges = list(graph.edges)
    return {frozenset(edges[i]) for i in np.flatnonzero(rng.random(len(edges)) < p_block)}


def grid_map(rng: np.random.Generator, w: int, h: int, p_block: float, diagonal: bool = False, stretch: float = 0.0):
    """A w x h grid (8-connected if ``diagonal``), lengths >= the straight line, random blocked ways."""
    graph = nx.grid_2d_graph(w, h)
    if diagonal:
        graph.add_edges_from(((x, y), (x + 1, y + 1)) for x in range(w - 1) for y in range(h - 1))
        graph.add_edges_from(((x + 1, y), (x, y + 1)) for x in range(w - 1) for y in range(h - 1))
    for v in graph:
        graph.nodes[v]["pos"] = (float(v[0]), float(v[1]))
    for u, v in graph.edges:
        graph.edges[u, v]["length"] = math.dist(u, v) * (1.0 + stretch * rng.random())
    return graph, random_blocked(rng, graph, p_block)


def geometric_map(rng: np.random.Generator, n: int, radius: float, p_block: float):
    graph = nx.random_geometric_graph(n, radius, seed=int(rng.integers(2**31)))
    for u, v in graph.edges:
        graph.edges[u, v]["length"] = math.dist(graph.nodes[u]["pos"], graph.nodes[v]["pos"])
    return graph, random_blocked(rng, graph, p_block)


def random_map(rng: np.random.Generator, kind: str):
    if kind == "grid":
        size = rng.integers(6, 25, size=2)
        return grid_map(rng, *size, rng.uniform(0, 0.3), stretch=float(rng.choice([0.0, 0.5])))
    if kind == "grid8":
        return grid_map(rng, *rng.integers(6, 20, size=2), rng.uniform(0, 0.3), diagonal=True)
    return geometric_map(rng, int(rng.integers(30, 301)), rng.uniform(0.1, 0.25), rng.uniform(0, 0.2))


def query(graph: nx.Graph, open_graph: nx.Graph, blocked: set[frozenset], a, b) -> tuple[float, tuple]:
    """The networkx optimum (inf if unreachable) and the results of astar, bidir-astar, bidir-astar-opt."""
    try:
        best = nx.shortest_path_length(open_graph, a, b, weight="length")
    except nx.NetworkXNoPath:
        best = math.inf
    return best, tuple(f(graph, a, b, blocked) for f in (astar, distributed_bidirectional_astar, bidirectional_astar_optimal))


def quality_rows(rng: np.random.Generator, kind: str, maps: int) -> tuple[dict[str, list[float]], int, int]:
    """Per-query statistics of one map kind: ({column: values}, unreachable, mismatches)."""
    rows = defaultdict(list)
    unreachable = mismatches = 0
    for _ in range(maps):
        graph, blocked = random_map(rng, kind)
        open_graph = graph.copy()
        open_graph.remove_edges_from(tuple(way) for way in blocked)
        nodes = list(graph)
        for _ in range(5):
            a, b = (nodes[j] for j in rng.choice(len(nodes), 2))
            best, (uni, paper, opt) = query(graph, open_graph, blocked, a, b)
            if math.isinf(best):
                unreachable += 1
                mismatches += sum(r.path is not None for r in (uni, paper, opt))
                continue
            mismatches += sum(abs(r.cost - best) > TOL for r in (uni, opt)) + (paper.cost < best - TOL)
            rows["ratio"].append(paper.cost / best if best > 0 else 1.0)
            rows["A*"].append(uni.expansions)
            rows["paper"].append(paper.expansions)
            rows["opt"].append(opt.expansions)
            rows["msg paper"].append(paper.messages)
            rows["msg opt"].append(opt.messages)
    return rows, unreachable, mismatches


def quality(maps_per_kind: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    print(f"Part 1: {maps_per_kind} maps per kind, 5 queries per map (seed {seed})")
    columns = (("A*", 7), ("paper", 9), ("opt", 7), ("msg paper", 9), ("msg opt", 7))
    header = f"{'map':<10} {'queries':>7} {'unreach':>7} {'mismatch':>8} {'subopt':>12} {'ratio mean':>10} {'ratio max':>9}"
    print(header + "".join(f" {'exp ' + k if k in ('A*', 'paper', 'opt') else k:>{w}}" for k, w in columns))
    totals = defaultdict(list)
    for kind in KINDS:
        rows, unreachable, mismatches = quality_rows(rng, kind, maps_per_kind)
        ratios = rows["ratio"]
        worse = sum(r > 1 + TOL for r in ratios)
        line = f"{kind:<10} {len(ratios) + unreachable:>7} {unreachable:>7} {mismatches:>8} "
        line += f"{worse:>4} ({100 * worse / len(ratios):4.1f}%) {statistics.mean(ratios):>10.4f} {max(ratios):>9.4f}"
        print(line + "".join(f" {statistics.mean(rows[k]):>{w}.2f}" for k, w in columns))
        for key in ("A*", "paper", "opt"):
            totals[key] += rows[key]
    mean = {k: statistics.mean(v) for k, v in totals.items()}
    print(
        f"all kinds: mean expansions A* {mean['A*']:.2f}, bidir-astar {mean['paper']:.2f}, "
        f"bidir-astar-opt {mean['opt']:.2f} ({mean['opt'] / mean['A*']:.3f} x A*)\n"
    )


def best_time(fn, repeat: int, min_total: float = 0.02) -> float:
    """Best-of-``repeat`` seconds per call, each round looping long enough to be measurable."""
    number = 1
    while timeit.timeit(fn, number=number) < min_total and number < 1 << 16:
        number *= 4
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


def timed_calls(graph: nx.Graph, open_graph: nx.Graph, blocked: set[frozenset], a, b) -> dict:
    """The calls timed for one query (networkx on the graph without the blocked ways)."""
    pos = nx.get_node_attributes(graph, "pos")
    return {
        "nx": lambda: nx.astar_path(open_graph, a, b, lambda u, v: math.dist(pos[u], pos[v]), weight="length"),
        "opt": lambda: bidirectional_astar_optimal(graph, a, b, blocked),
        "astar": lambda: astar(graph, a, b, blocked),
        "paper": lambda: distributed_bidirectional_astar(graph, a, b, blocked),
    }


def time_map(rng: np.random.Generator, w: int, h: int, queries: int, repeat: int) -> dict[str, float]:
    """Mean over ``queries`` random connected queries of the best-of-``repeat`` seconds per planner (and expansions)."""
    graph, blocked = grid_map(rng, w, h, 0.1)
    open_graph = graph.copy()
    open_graph.remove_edges_from(tuple(way) for way in blocked)
    part = sorted(max(nx.connected_components(open_graph), key=len))
    SearchGraph.of(graph)  # prepared once, as networkx's graph is
    times = defaultdict(float)
    for _ in range(queries):
        a, b = (part[j] for j in rng.choice(len(part), 2, replace=False))
        for key, fn in timed_calls(graph, open_graph, blocked, a, b).items():
            times[key] += best_time(fn, repeat) / queries
        times["exp A*"] += astar(graph, a, b, blocked).expansions / queries
        times["exp opt"] += bidirectional_astar_optimal(graph, a, b, blocked).expansions / queries
    return times


def speed(queries: int, repeat: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    print(f"Part 2: time per query, mean over {queries} queries of the best of {repeat} (10 % of ways blocked)")
    print(f"{'map':<18} {'networkx':>10} {'opt':>10} {'opt/nx':>7} {'astar':>10} {'paper':>10} {'exp A*':>8} {'exp opt':>8}")
    for w, h in ((8, 5), (100, 100)):
        times = time_map(rng, w, h, queries, repeat)
        ms = {k: f"{1e3 * v:.4f} ms" if v < 1e-3 else f"{1e3 * v:.2f} ms" for k, v in times.items() if "exp" not in k}
        line = f"{f'grid {w}x{h} ({w * h})':<18} {ms['nx']:>10} {ms['opt']:>10} {times['opt'] / times['nx']:>6.2f}x"
        print(f"{line} {ms['astar']:>10} {ms['paper']:>10} {times['exp A*']:>8.1f} {times['exp opt']:>8.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", type=int, default=200, help="random maps per kind in part 1")
    parser.add_argument("--queries", type=int, default=20, help="timed queries per map in part 2")
    parser.add_argument("--repeat", type=int, default=5, help="timing rounds per query and planner (best kept)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(f"Python {platform.python_version()}, networkx {nx.__version__}, {platform.machine()}\n")
    quality(args.maps, args.seed)
    speed(args.queries, args.repeat, args.seed)


if __name__ == "__main__":
    main()
