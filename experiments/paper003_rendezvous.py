"""Paper 003 (rendezvous on a graph of places and ways): the planner sweep and env-level episodes.

    python experiments/paper003_rendezvous.py planners [--maps 1000] [--replans 2] [--places 20 10000]
        [--seed 0] [--workers 1] [--out results/paper003]
    python experiments/paper003_rendezvous.py episodes [--seeds 100] [--places 20 200]
        [--seed 0] [--workers 1] [--out results/paper003]

Subcommands (each writes ``<name>.json`` and ``<name>.md`` into ``--out``; exit code 1 on a
check that failed):

* ``planners``: ``--maps`` random maps, map *i* drawn from ``numpy.random.default_rng([seed,
  0, i])`` (so results do not depend on ``--workers``); kinds alternate between ``grid`` and
  ``voronoi`` (:mod:`teamgym.maps.abstraction`); sizes
  log-uniform in ``--places``; a random 0-20 % of the ways blocked. Per map one query between
  two random places of the largest connected part, then ``--replans`` re-planning queries: a
  random way of the current optimal path that has a detour becomes blocked (plus up to 2 %
  more ways at random, unless they cut the robots apart), robot A stands before it and robot
  B further along the path (a map without such a way has fewer queries). Every planner of
  ``PLANNERS`` answers every query;
  recorded: cost over networkx's optimum (``bidirectional_dijkstra`` on the map without the
  blocked ways), expansions against ``astar`` on the same query, messages and the places they
  carry, planning time. Reported per map kind and size bucket (20-100, 100-1,000,
  1,000-10,000 places). ``bidir-astar-opt`` must match the optimum on every query: if not,
  a loud FAILURE is printed and the exit code is 1.
* ``episodes``: ``Rendezvous-v0`` on ``--seeds`` random maps of ``--places`` places (episode
  *i*: map from ``default_rng([seed, 1, i])``, written to ``--out/maps/``, env seed
  ``seed + i``; kinds alternate as above), the median way ``WORLD_SPACING`` m long in the
  world, a random 0-15 % of the ways blocked from the start (keeping the map connected; only
  ways of at least ``MIN_BLOCKED_WAY`` m), random start places, and four settings: blockings
  ``start`` or ``start+rate`` (plus random blockings at 0.2 % of the ways per second: the
  env's ``block_rate``, or the same process as timed ``blockings`` on maps with shorter ways)
  × channel throughput 1.0 or 0.5. Policies ``bidir-astar``, ``bidir-astar-opt`` (the
  protocol's Phase 3 timing ``execution="paper"``), ``bidir-astar-eager`` (the former timing,
  ``execution="eager"``) and ``centralized`` play the same map and seed: success, meeting time (also over
  ``centralized``'s on the same episode), worst plan optimality per episode, plans and
  re-plans, channel messages and bytes (team), expansions. Corridor walls only up to
  ``WALLS_MAX_PLACES`` places (speed); ``message_len`` fits two whole paths.

Maps come from :mod:`teamgym.maps.abstraction` (``random_grid_map``, ``random_voronoi_map``).
The paper's scenario maps (Figs. 5 and 8) are in ``experiments/paper003_scenarios.py``.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import importlib.util
import json
import math
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

import teamgym
from baselines.episode import run_episode
from baselines.registry import make_policy, required_config
from baselines.rendezvous.search import PLANNERS, SearchGraph
from baselines.runners import pool_map
from baselines.summary import write_summary_json
from teamgym.envs.rendezvous.config import RendezvousConfig
from teamgym.maps.graph import GraphMap, graph_map_from_dict, save_graph_map

TOL = 1e-9
"""Relative tolerance of cost comparisons."""
BUCKETS = ((20, 100, "20-100"), (100, 1000, "100-1,000"), (1000, math.inf, "1,000-10,000"))
"""Size buckets (places): ``low <= n < high``."""
BLOCKED_SHARE = (0.0, 0.2)
"""Share of the ways blocked in a planner-sweep map (uniform in this range)."""
REPLAN_EXTRA_SHARE = (0.0, 0.02)
"""Share of the open ways blocked besides the way on the path before a re-planning query."""
EPISODE_POLICIES = ("bidir-astar", "bidir-astar-opt", "bidir-astar-eager", "centralized")
EPISODE_BLOCKED_SHARE = (0.0, 0.15)
BLOCK_RATE_PER_WAY = 0.002
"""Rate of random blockings (1/s) of the ``start+rate`` setting per way of the map: the env's
``block_rate``, or the same Poisson process drawn here as timed ``blockings`` on maps with ways
shorter than :data:`MIN_BLOCKED_WAY`."""
THROUGHPUTS = (1.0, 0.5)
BLOCKINGS = ("start", "start+rate")
WALLS_MAX_PLACES = 100
"""Maps with more places run with ``corridor_walls=False`` (walls cost ~10x the episode time)."""
MIN_BLOCKED_WAY = 0.2
"""Ways shorter than this (m, in the world) are never blocked: the env's blocker would cover their ends."""
WORLD_SPACING = 0.5
"""The env's ``scale`` puts the median way at this many metres."""
MAX_CYCLES = 10_000
"""Episode limit in control cycles (1,000 s at dt = 0.1 s): long Voronoi detours need several hundred seconds."""
GENERATOR_ATTEMPTS = 5
"""Attempts of a map generator (fresh random draws each) before the map is skipped."""
ABSTRACTION = "teamgym.maps.abstraction."
GENERATORS = {"grid": ABSTRACTION + "random_grid_map", "voronoi": ABSTRACTION + "random_voronoi_map"}


# -- maps -----------------------------------------------------------------------------------------------
class MapGenerationError(ValueError):
    """A map generator failed :data:`GENERATOR_ATTEMPTS` times in a row (the map is skipped)."""


def map_generators() -> dict[str, str]:
    """The generator of each map kind (recorded in a run's JSON)."""
    return dict(GENERATORS)


def map_kinds() -> tuple[str, ...]:
    """The map kinds: ``grid`` and ``voronoi``."""
    return tuple(GENERATORS)


def _as_networkx(made: Any) -> nx.Graph:
    if isinstance(made, GraphMap):
        return made.to_networkx()
    if isinstance(made, nx.Graph):
        return made
    raise TypeError(f"a map generator returned {type(made).__name__}, expected a GraphMap or a networkx.Graph")


def random_graph(kind: str, n_places: int, rng: np.random.Generator, generators: dict[str, str] | None = None) -> nx.Graph:
    """A random map of about ``n_places`` places as a networkx graph (node ``pos``, edge ``length``).

    ``generators`` (default :data:`GENERATORS`) names the function of each kind; grids get a
    random share of diagonals in [0, 0.3].
    A generator's ValueError is retried with the next random draws (``graph.graph
    ["generator_retries"]`` counts them); after :data:`GENERATOR_ATTEMPTS` attempts
    :class:`MapGenerationError` is raised.
    """
    generators = map_generators() if generators is None else generators
    if kind not in generators:
        raise ValueError(f"unknown or unavailable map kind {kind!r}; available: {sorted(generators)}")
    name = generators[kind]
    function = getattr(importlib.import_module(ABSTRACTION.rstrip(".")), name.removeprefix(ABSTRACTION))
    for attempt in range(GENERATOR_ATTEMPTS):
        try:
            if kind == "voronoi":
                graph = _as_networkx(function(rng, n_places))
            else:
                graph = _as_networkx(function(n_places, rng, diagonals=float(rng.uniform(0.0, 0.3))))
        except ValueError as error:  # e.g. a random workspace whose obstacles do not fit: draw again
            failure = error
            continue
        graph.graph["generator_retries"] = attempt
        return graph
    raise MapGenerationError(f"{name}({n_places} places) failed {GENERATOR_ATTEMPTS} times; last: {failure}")


def to_graph_map(graph: nx.Graph, name: str) -> GraphMap:
    """The graph as a validated :class:`GraphMap` (place ids are ``str(node)``)."""
    places = [{"id": str(v), "x": float(graph.nodes[v]["pos"][0]), "y": float(graph.nodes[v]["pos"][1])} for v in graph]
    ways = []
    for u, v, data in graph.edges(data=True):
        way = {"a": str(u), "b": str(v), "length": float(data["length"])}
        if data.get("width") is not None:
            way["width"] = float(data["width"])
        ways.append(way)
    return graph_map_from_dict({"name": name, "places": places, "ways": ways}, source=name)


def log_uniform_size(rng: np.random.Generator, places: tuple[int, int]) -> int:
    """A place count log-uniform in ``places`` (inclusive)."""
    low, high = places
    return int(min(high, max(low, round(math.exp(rng.uniform(math.log(low), math.log(high)))))))


def bucket_of(n_places: int) -> str:
    """The label of the size bucket holding ``n_places``."""
    for low, high, label in BUCKETS:
        if n_places < high:
            return label if n_places >= low else f"<{low}"
    return BUCKETS[-1][2]


def _pick(rng: np.random.Generator, items: Sequence[Any]) -> Any:
    return items[int(rng.integers(len(items)))]


# -- the planner sweep ---------------------------------------------------------------------------------
def _path_cost(graph: nx.Graph, path: Sequence[Any] | None, blocked: set[frozenset]) -> float:
    """Cost of ``path`` on the open map (inf if it uses a blocked way or no way)."""
    if not path:
        return math.inf
    cost = 0.0
    for u, v in zip(path, path[1:]):
        if frozenset((u, v)) in blocked or not graph.has_edge(u, v):
            return math.inf
        cost += graph.edges[u, v]["length"]
    return cost


def _run_query(graph: nx.Graph, open_graph: nx.Graph, blocked: set[frozenset], a: Any, b: Any) -> dict[str, Any]:
    """Every planner on one query, against networkx's optimum; also returns the optimal path."""
    optimum, best_path = nx.bidirectional_dijkstra(open_graph, a, b, weight="length")
    pairs = [tuple(w) for w in blocked]
    record: dict[str, Any] = {"optimum": float(optimum), "path_places": len(best_path), "_path": best_path}
    for name, planner in PLANNERS.items():
        started = time.perf_counter()
        result = planner(graph, a, b, pairs)
        elapsed = time.perf_counter() - started
        walked = _path_cost(graph, result.path, blocked)
        record[name] = {
            "cost": result.cost,
            "ratio": result.cost / optimum if optimum > 0 else 1.0,
            "optimal": abs(result.cost - optimum) <= TOL * max(1.0, optimum),
            "valid": result.found and abs(walked - result.cost) <= TOL * max(1.0, walked),
            "expansions": result.expansions,
            "messages": result.messages,
            "message_places": result.message_places,
            "time_ms": 1000 * elapsed,
        }
    return record


def _block_on_path(
    graph: nx.Graph, open_graph: nx.Graph, blocked: set[frozenset], path: Sequence[Any], rng: np.random.Generator
) -> int | None:
    """Block a random way ``path[k]-path[k+1]`` that has a detour in ``open_graph``; return ``k`` (None if none has)."""
    for k in rng.permutation(len(path) - 1).tolist():
        u, v = path[k], path[k + 1]
        open_graph.remove_edge(u, v)
        if nx.has_path(open_graph, u, v):
            blocked.add(frozenset((u, v)))
            return k
        open_graph.add_edge(u, v, **graph.edges[u, v])
    return None


def sweep_map(index: int, seed: int, generators: dict[str, str], places: tuple[int, int], replans: int) -> dict[str, Any]:
    """One map of the planner sweep: its first query and ``replans`` re-planning queries."""
    rng = np.random.default_rng([seed, 0, index])
    kind = list(generators)[index % len(generators)]
    n_places = log_uniform_size(rng, places)
    try:
        graph = random_graph(kind, n_places, rng, generators)
    except MapGenerationError as error:
        return {
            "map": index,
            "kind": kind,
            "places": n_places,
            "generator_retries": GENERATOR_ATTEMPTS,
            "queries": [],
            "skipped": str(error),
        }
    SearchGraph.of(graph)  # prepared once, before any timing
    nodes = list(graph)
    edges = list(graph.edges)
    share = rng.uniform(*BLOCKED_SHARE)
    blocked = {frozenset(edges[k]) for k in np.flatnonzero(rng.random(len(edges)) < share)}
    open_graph = graph.copy()
    open_graph.remove_edges_from(tuple(w) for w in blocked)
    info = {"map": index, "kind": kind, "places": len(nodes), "ways": len(edges), "blocked_share": share}
    info["generator_retries"] = graph.graph.get("generator_retries", 0)
    largest = max(nx.connected_components(open_graph), key=len)
    if len(largest) < 2:
        return {**info, "queries": [], "skipped": "no two connected places"}
    members = [v for v in nodes if v in largest]  # in node order: independent of set order
    a, b = (members[i] for i in rng.choice(len(members), size=2, replace=False))
    queries = []
    for q in range(replans + 1):
        record = _run_query(graph, open_graph, blocked, a, b)
        path = record.pop("_path")
        queries.append({**info, "query": "first" if q == 0 else "replan", "blocked": len(blocked), **record})
        if q == replans:
            break
        k = _block_on_path(graph, open_graph, blocked, path, rng)  # robot A at path[k] finds path[k]-path[k+1] blocked
        if k is None:
            break
        j = int(rng.integers(k + 1, len(path)))  # robot B came from the far end to path[j]
        extra = [edges[i] for i in np.flatnonzero(rng.random(len(edges)) < rng.uniform(*REPLAN_EXTRA_SHARE))]
        extra = [(u, v) for u, v in extra if frozenset((u, v)) not in blocked]
        open_graph.remove_edges_from(extra)
        if nx.has_path(open_graph, path[k], path[j]):
            blocked.update(frozenset(w) for w in extra)
        else:  # the extra blockings cut the robots apart: leave them out
            open_graph.add_edges_from((u, v, graph.edges[u, v]) for u, v in extra)
        a, b = path[k], path[j]
    return {**info, "queries": queries}


def _parallel(task: Callable[..., Any], jobs: Sequence[tuple], workers: int) -> list[Any]:
    """``task(*job)`` for every job, in order, in ``workers`` spawned processes (1: in this one).

    Workers import this module by name: when it is loaded from its file with importlib, register
    it in ``sys.modules`` under its name first.
    """
    here = str(Path(__file__).resolve().parent)
    if workers > 1 and here not in sys.path:  # spawned workers import this module by name
        sys.path.insert(0, here)
    return pool_map(task, jobs, workers, star=True, start_method="spawn")


def _mean(values: Iterable[float]) -> float:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else math.nan


def summarise_queries(queries: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Optimality, search effort, messages and time of a group of queries."""
    n = len(queries)
    ratios = [q["bidir-astar"]["ratio"] for q in queries]
    astar_exp = sum(q["astar"]["expansions"] for q in queries)
    row: dict[str, Any] = {
        "queries": n,
        "bidir-astar suboptimal": _mean(r > 1 + TOL for r in ratios),
        "bidir-astar ratio mean": _mean(ratios),
        "bidir-astar ratio max": max(ratios, default=math.nan),
        "bidir-astar-opt optimal": _mean(q["bidir-astar-opt"]["optimal"] for q in queries),
        "astar optimal": _mean(q["astar"]["optimal"] for q in queries),
        "astar expansions": astar_exp / n if n else math.nan,
    }
    for name in ("bidir-astar", "bidir-astar-opt"):
        row[f"{name} expansions / astar"] = sum(q[name]["expansions"] for q in queries) / astar_exp if astar_exp else math.nan
        row[f"{name} messages"] = _mean(q[name]["messages"] for q in queries)
        row[f"{name} message places"] = _mean(q[name]["message_places"] for q in queries)
    for name in PLANNERS:
        row[f"{name} time_ms"] = _mean(q[name]["time_ms"] for q in queries)
    return row


def planner_failures(queries: Sequence[dict[str, Any]]) -> list[str]:
    """Queries where ``bidir-astar-opt`` or ``astar`` missed the optimum, or a planner beat it or returned a bad path."""
    problems = []
    for q in queries:
        where = f"map {q['map']} ({q['kind']}, {q['places']} places), {q['query']} query"
        for name in ("bidir-astar-opt", "astar"):
            if not q[name]["optimal"]:
                problems.append(f"{where}: {name} cost {q[name]['cost']!r} vs optimum {q['optimum']!r}")
        for name in PLANNERS:
            if not q[name]["valid"] or q[name]["cost"] < q["optimum"] * (1 - TOL) - TOL:
                problems.append(f"{where}: {name} returned an invalid path or one below the optimum ({q[name]['cost']!r})")
    return problems


def planner_sweep(
    maps: int = 1000, seed: int = 0, places: tuple[int, int] = (20, 10_000), replans: int = 2, workers: int = 1
) -> dict[str, Any]:
    """The ``planners`` experiment: per-query records, rows per map kind and size bucket, failures."""
    generators = map_generators()
    kinds = tuple(generators)
    started = time.perf_counter()
    jobs = [(i, seed, generators, tuple(places), replans) for i in range(maps)]
    results = _parallel(sweep_map, jobs, workers)
    queries = [q for r in results for q in r["queries"]]
    rows = []
    for kind in kinds:
        for label in [b[2] for b in BUCKETS] + ["all"]:
            group = [q for q in queries if q["kind"] == kind and label in (bucket_of(q["places"]), "all")]
            if group:
                rows.append({"kind": kind, "places": label, "maps": len({q["map"] for q in group}), **summarise_queries(group)})
    if len(kinds) > 1:
        rows.append({"kind": "all", "places": "all", "maps": len({q["map"] for q in queries}), **summarise_queries(queries)})
    by_query = [
        {"query": kind, **summarise_queries([q for q in queries if q["query"] == kind])}
        for kind in ("first", "replan")
        if any(q["query"] == kind for q in queries)
    ]
    return {
        "config": {
            "maps": maps,
            "seed": seed,
            "places": list(places),
            "replans": replans,
            "kinds": list(kinds),
            "generators": generators,
            "blocked_share": list(BLOCKED_SHARE),
            "replan_extra_share": list(REPLAN_EXTRA_SHARE),
            "workers": workers,
        },
        "rows": rows,
        "by_query": by_query,
        "failures": planner_failures(queries),
        "skipped_maps": [{"map": r["map"], "reason": r["skipped"]} for r in results if r.get("skipped")],
        "generator_retries": sum(r["generator_retries"] for r in results),
        "wall_s": time.perf_counter() - started,
        "queries": queries,
    }


# -- env-level episodes ----------------------------------------------------------------------------------
def _connected_blocking(
    graph: nx.Graph, candidates: Sequence[tuple[str, str]], count: int, rng: np.random.Generator
) -> list[tuple[str, str]]:
    """Up to ``count`` random ways of ``candidates``, each blocked only if ``graph`` (changed in place) stays connected."""
    blocked: list[tuple[str, str]] = []
    for k in rng.permutation(len(candidates)):
        if len(blocked) >= count:
            break
        u, v = candidates[k]
        graph.remove_edge(u, v)
        if nx.has_path(graph, u, v):
            blocked.append((u, v))
        else:
            graph.add_edge(u, v)
    return blocked


def _timed_blockings(
    graph: nx.Graph, candidates: Sequence[tuple[str, str]], rate: float, horizon: float, rng: np.random.Generator
) -> list[tuple[str, str, float]]:
    """Random blockings ``(a, b, t)`` at the times of a Poisson process of ``rate`` (1/s) up to ``horizon`` s.

    As the env's ``block_rate`` does: each picks a random way not yet blocked (of ``candidates``)
    and is dropped if its loss would disconnect the map (``graph``, changed in place).
    """
    out: list[tuple[str, str, float]] = []
    t = rng.exponential(1 / rate) if rate > 0 else math.inf
    while t <= horizon:
        free = [(u, v) for u, v in candidates if graph.has_edge(u, v)]
        if not free:
            break
        u, v = free[int(rng.integers(len(free)))]
        graph.remove_edge(u, v)
        if nx.has_path(graph, u, v):
            out.append((u, v, round(float(t), 3)))
        else:
            graph.add_edge(u, v)
        t += rng.exponential(1 / rate)
    return out


def episode_scenario(
    index: int, seed: int, generators: dict[str, str], places: tuple[int, int], maps_dir: Path
) -> dict[str, Any]:
    """Episode ``index``: its map (written to ``maps_dir``), env scale, blocked ways and start places.

    A map that cannot be generated gives ``{"episode", "kind", "places", "skipped": reason}``.

    The scale puts the median way at :data:`WORLD_SPACING` m. Only ways at least
    :data:`MIN_BLOCKED_WAY` m long are blocked (the env's blocker of a shorter way covers its
    end places). ``timed_blockings`` stand in for ``block_rate`` on maps with shorter ways.
    """
    rng = np.random.default_rng([seed, 1, index])
    kind = list(generators)[index % len(generators)]
    n_places = log_uniform_size(rng, places)
    try:
        graph = random_graph(kind, n_places, rng, generators)
    except MapGenerationError as error:
        return {"episode": index, "kind": kind, "places": n_places, "skipped": str(error)}
    graph = nx.relabel_nodes(graph, {v: str(v) for v in graph})
    lengths = [d["length"] for *_, d in graph.edges(data=True)]
    scale = float(np.clip(WORLD_SPACING / float(np.median(lengths)), 0.05, 100.0))
    name = f"e{index:04d}_{kind}_{graph.number_of_nodes()}"
    graph_map = to_graph_map(graph, name)
    text = json.dumps(graph_map.to_dict(), sort_keys=True)
    path = maps_dir / f"{name}_{hashlib.sha1(text.encode()).hexdigest()[:8]}.json"
    if not path.exists():
        save_graph_map(graph_map, path)
    candidates = [(u, v) for u, v, d in graph.edges(data=True) if d["length"] * scale >= MIN_BLOCKED_WAY]
    remaining = graph.copy()
    count = round(rng.uniform(*EPISODE_BLOCKED_SHARE) * graph.number_of_edges())
    blocked = _connected_blocking(remaining, candidates, count, rng)
    short = len(candidates) < graph.number_of_edges()
    rate = BLOCK_RATE_PER_WAY * graph.number_of_edges()
    timed = _timed_blockings(remaining, candidates, rate, MAX_CYCLES * RendezvousConfig.dt, rng) if short else []
    nodes = list(graph)
    pos = nx.get_node_attributes(graph, "pos")
    a = _pick(rng, nodes)
    far = [v for v in nodes if math.dist(pos[a], pos[v]) * scale > 3 * RendezvousConfig.meet_distance]
    return {
        "episode": index,
        "seed": seed + index,
        "kind": kind,
        "places": len(nodes),
        "ways": graph.number_of_edges(),
        "short_ways": graph.number_of_edges() - len(candidates),
        "generator_retries": graph.graph.get("generator_retries", 0),
        "map": str(path),
        "scale": scale,
        "blocked_ways": blocked,
        "block_rate": 0.0 if short else rate,
        "timed_blockings": timed,
        "start_places": [a, _pick(rng, far or [v for v in nodes if v != a])],
    }


def episode_config(scenario: dict[str, Any], blocking: str, throughput: float) -> dict[str, Any]:
    """The ``Rendezvous-v0`` config of one scenario and setting (the policies' required keys included).

    ``message_len`` fits two whole paths (the protocol may repeat a PATH in the message that
    carries a new one) and the other records.
    """
    config = {
        **required_config(EPISODE_POLICIES[0]),
        "map": scenario["map"],
        "scale": scenario["scale"],
        "start_places": tuple(scenario["start_places"]),
        "blocked_ways": tuple(tuple(w) for w in scenario["blocked_ways"]),
        "comm_throughput": throughput,
        "corridor_walls": scenario["places"] <= WALLS_MAX_PLACES,
        "max_cycles": MAX_CYCLES,
        "message_len": 2 * scenario["places"] + 64,
    }
    if "rate" in blocking:
        config["block_rate"] = scenario["block_rate"]
        config["blockings"] = tuple(tuple(b) for b in scenario["timed_blockings"])
    return config


def run_scenario(scenario: dict[str, Any], settings: Sequence[tuple[str, float]]) -> list[dict[str, Any]]:
    """Every setting × policy on one scenario: one record per episode.

    An exception inside an episode (env or policy) does not stop the run: the episode counts
    as failed, its record carries ``error`` and no metrics.
    """
    records = []
    for blocking, throughput in settings:
        env = teamgym.make("Rendezvous-v0", **episode_config(scenario, blocking, throughput))
        for name in EPISODE_POLICIES:
            record = {
                "episode": scenario["episode"],
                "seed": scenario["seed"],
                "kind": scenario["kind"],
                "places": scenario["places"],
                "blocked_start": len(scenario["blocked_ways"]),
                "blocking": blocking,
                "throughput": throughput,
                "policy": name,
            }
            started = time.perf_counter()
            try:
                result = run_episode(env, make_policy(name, env), scenario["seed"], record_trajectories=False)
            except Exception as error:  # noqa: BLE001 - reported in the results, the run goes on
                record.update(success=False, error=f"{type(error).__name__}: {error}", wall_s=time.perf_counter() - started)
                records.append(record)
                continue
            first = result.metrics[env.possible_agents[0]]
            team = result.metrics.values()
            record.update(
                success=result.success,
                steps=result.length,
                meeting_time=first.get("meeting_time"),
                optimality=first.get("optimality"),
                plans=first["plans"],
                replans=first["replans"],
                expansions=first["expansions"],
                blocked_known=max(m["blocked_known"] for m in team),
                messages=sum(m["messages_sent"] for m in team),
                bytes=sum(m["bytes_sent"] for m in team),
                bytes_delivered=sum(m["bytes_delivered"] for m in team),
                path_length=sum(m["path_length"] for m in team),
                failed_moves=sum(m.get("failed_moves", 0) for m in team),
                wall_s=time.perf_counter() - started,
            )
            records.append(record)
        env.close()
    return records


def summarise_episodes(records: Sequence[dict[str, Any]], reference: Sequence[dict[str, Any]] = ()) -> dict[str, Any]:
    """Success, meeting time (absolute and over ``reference``'s on the same episode), optimality, plans, messages."""
    met = {(r["episode"], r["blocking"], r["throughput"]): r["meeting_time"] for r in reference if r["success"]}
    relative = [
        r["meeting_time"] / met[key]
        for r in records
        if r["success"] and (key := (r["episode"], r["blocking"], r["throughput"])) in met and met[key] > 0
    ]
    optimality = [r["optimality"] for r in records if r.get("optimality") is not None]
    return {
        "episodes": len(records),
        "success": _mean(r["success"] for r in records),
        "errors": sum("error" in r for r in records),
        "meeting time (s)": _mean(r["meeting_time"] for r in records if r["success"]),
        "meeting time / centralized": _mean(relative),
        "meeting time / centralized max": max(relative, default=math.nan),
        "worst optimality mean": _mean(optimality),
        "worst optimality max": max(optimality, default=math.nan),
        "suboptimal plan": _mean(o > 1 + TOL for o in optimality),
        "plans": _mean(r.get("plans") for r in records),
        "replans": _mean(r.get("replans") for r in records),
        "messages": _mean(r.get("messages") for r in records),
        "bytes": _mean(r.get("bytes") for r in records),
        "expansions": _mean(r.get("expansions") for r in records),
        "steps": _mean(r.get("steps") for r in records),
        "failed moves": _mean(r.get("failed_moves") for r in records),
    }


def episode_runs(
    seeds: int = 100, seed: int = 0, places: tuple[int, int] = (20, 200), workers: int = 1, out: Path | None = None
) -> dict[str, Any]:
    """The ``episodes`` experiment: per-episode records, rows per setting and policy, failed episodes."""
    out = Path(out or "results/paper003")
    maps_dir = out / "maps"
    maps_dir.mkdir(parents=True, exist_ok=True)
    generators = map_generators()
    started = time.perf_counter()
    drawn = [episode_scenario(i, seed, generators, tuple(places), maps_dir) for i in range(seeds)]
    scenarios = {s["episode"]: s for s in drawn if "skipped" not in s}
    settings = [(b, t) for b in BLOCKINGS for t in THROUGHPUTS]
    jobs = [(s, settings) for s in scenarios.values()]
    records = [r for batch in _parallel(run_scenario, jobs, workers) for r in batch]
    rows = []
    for blocking, throughput in settings:
        group = [r for r in records if r["blocking"] == blocking and r["throughput"] == throughput]
        for name in EPISODE_POLICIES:
            mine = [r for r in group if r["policy"] == name]
            summary = summarise_episodes(mine, [r for r in group if r["policy"] == "centralized"])
            rows.append({"blocking": blocking, "throughput": throughput, "policy": name, **summary})
    by_kind = []
    for kind in generators:
        group = [r for r in records if r["kind"] == kind]
        reference = [r for r in group if r["policy"] == "centralized"]
        for name in EPISODE_POLICIES:
            summary = summarise_episodes([r for r in group if r["policy"] == name], reference)
            by_kind.append({"kind": kind, "policy": name, **summary})
    failed = [
        {
            **{k: r.get(k) for k in ("episode", "seed", "kind", "places", "blocking", "throughput", "policy", "steps", "error")},
            "config": episode_config(scenarios[r["episode"]], r["blocking"], r["throughput"]),
        }
        for r in records
        if not r["success"]
    ]
    return {
        "config": {
            "seeds": seeds,
            "seed": seed,
            "places": list(places),
            "kinds": list(generators),
            "generators": generators,
            "policies": list(EPISODE_POLICIES),
            "blockings": list(BLOCKINGS),
            "throughputs": list(THROUGHPUTS),
            "blocked_share": list(EPISODE_BLOCKED_SHARE),
            "block_rate_per_way": BLOCK_RATE_PER_WAY,
            "min_blocked_way_m": MIN_BLOCKED_WAY,
            "world_spacing_m": WORLD_SPACING,
            "walls_max_places": WALLS_MAX_PLACES,
            "max_cycles": MAX_CYCLES,
            "workers": workers,
        },
        "rows": rows,
        "by_kind": by_kind,
        "failed": failed,
        "wall_s": time.perf_counter() - started,
        "skipped_maps": [s for s in drawn if "skipped" in s],
        "scenarios": list(scenarios.values()),
        "episodes": records,
    }


# -- tables -------------------------------------------------------------------------------------------
def _cell(value: Any, kind: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if kind == "%":
        return f"{100 * value:.1f} %"
    if kind == "ratio":
        return f"{value:.4f}"
    if kind == "int":
        return f"{value:,.0f}"
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:,.0f}"
    return str(value)


def table(rows: Sequence[dict[str, Any]], columns: Sequence[tuple[str, str, str]]) -> str:
    """A Markdown table of ``rows``; ``columns`` are ``(key, header, format)`` (format ``%``, ``ratio``, ``int`` or ``""``)."""
    lines = ["| " + " | ".join(h for _, h, _ in columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row.get(k), f) for k, _, f in columns) + " |")
    return "\n".join(lines)


def planners_markdown(result: dict[str, Any]) -> str:
    """``planners.md``: optimality, search effort and time tables."""
    c = result["config"]
    head = [("kind", "map kind", ""), ("places", "places", ""), ("maps", "maps", "int"), ("queries", "queries", "int")]
    text = [
        "## planners",
        "",
        f"{c['maps']} random maps (kinds {', '.join(c['kinds'])}; generators {c['generators']}), "
        f"{c['places'][0]}-{c['places'][1]} places log-uniform, {100 * c['blocked_share'][1]:.0f} % of the ways "
        f"blocked at most; 1 query + {c['replans']} re-planning queries per map; seed {c['seed']}; "
        f"{result['wall_s']:.0f} s wall; {result['generator_retries']} map generator error(s) (each redrawn; "
        f"{len(result['skipped_maps'])} map(s) skipped after {GENERATOR_ATTEMPTS} in a row).",
        "",
        "Optimality (cost over networkx's optimum; suboptimal: ratio > 1 + 1e-9):",
        "",
        table(
            result["rows"],
            head
            + [
                ("bidir-astar suboptimal", "bidir-astar suboptimal", "%"),
                ("bidir-astar ratio mean", "ratio mean", "ratio"),
                ("bidir-astar ratio max", "ratio max", "ratio"),
                ("bidir-astar-opt optimal", "bidir-astar-opt optimal", "%"),
                ("astar optimal", "astar optimal", "%"),
            ],
        ),
        "",
        "Search effort (expansions: total over total of `astar` on the same queries; messages per query "
        "and the places they carry):",
        "",
        table(
            result["rows"],
            head[:2]
            + [
                ("astar expansions", "astar expansions", ""),
                ("bidir-astar expansions / astar", "bidir-astar exp / astar", "ratio"),
                ("bidir-astar-opt expansions / astar", "bidir-astar-opt exp / astar", "ratio"),
                ("bidir-astar messages", "bidir-astar messages", ""),
                ("bidir-astar message places", "bidir-astar msg places", ""),
                ("bidir-astar-opt messages", "bidir-astar-opt messages", ""),
                ("bidir-astar-opt message places", "bidir-astar-opt msg places", ""),
            ],
        ),
        "",
        "Planning time per query (ms, mean; `centralized` is networkx Dijkstra):",
        "",
        table(result["rows"], head[:2] + [(f"{n} time_ms", n, "") for n in PLANNERS]),
        "",
        "By query (first plan vs re-planning after extra blockings):",
        "",
        table(
            result["by_query"],
            [
                ("query", "query", ""),
                ("queries", "queries", "int"),
                ("bidir-astar suboptimal", "bidir-astar suboptimal", "%"),
                ("bidir-astar ratio mean", "ratio mean", "ratio"),
                ("bidir-astar ratio max", "ratio max", "ratio"),
                ("bidir-astar-opt optimal", "bidir-astar-opt optimal", "%"),
                ("bidir-astar expansions / astar", "bidir-astar exp / astar", "ratio"),
                ("bidir-astar-opt expansions / astar", "bidir-astar-opt exp / astar", "ratio"),
            ],
        ),
        "",
    ]
    if result["failures"]:
        text += [f"**FAILURE: {len(result['failures'])} check(s) failed:**", ""] + [f"* {f}" for f in result["failures"][:50]]
    else:
        text.append("Check: `bidir-astar-opt` and `astar` matched the optimum on 100 % of the queries.")
    return "\n".join(text) + "\n"


def episodes_markdown(result: dict[str, Any]) -> str:
    """``episodes.md``: one row per setting and policy."""
    c = result["config"]
    text = [
        "## episodes",
        "",
        f"Rendezvous-v0, {c['seeds']} random maps per setting ({', '.join(c['kinds'])}; "
        f"{c['places'][0]}-{c['places'][1]} places log-uniform), 0-{100 * c['blocked_share'][1]:.0f} % of the ways "
        f"blocked from the start (ways of at least {c['min_blocked_way_m']} m); `start+rate` adds random blockings at "
        f"{c['block_rate_per_way']} × ways per s (the env's block_rate, or as timed blockings on maps with shorter "
        "ways); "
        f"corridor walls up to {c['walls_max_places']} places; seeds {c['seed']}..{c['seed'] + c['seeds'] - 1}; "
        f"{result['wall_s']:.0f} s wall; {len(result['skipped_maps'])} map(s) skipped (generator errors). "
        "Meeting time over `centralized`: same map, seed and setting, both met. "
        "Worst optimality: the episode's worst announced plan (cost over the optimum on the map as the team "
        "knew it). Messages and bytes: sent by the team through the channel.",
        "",
        table(
            result["rows"],
            [
                ("blocking", "blocking", ""),
                ("throughput", "throughput", ""),
                ("policy", "policy", ""),
                ("episodes", "episodes", "int"),
                ("success", "success", "%"),
                ("errors", "errors", "int"),
                ("meeting time (s)", "meeting time (s)", ""),
                ("meeting time / centralized", "vs centralized", "ratio"),
                ("meeting time / centralized max", "vs centralized max", "ratio"),
                ("worst optimality mean", "worst optimality mean", "ratio"),
                ("worst optimality max", "worst optimality max", "ratio"),
                ("suboptimal plan", "episodes with a suboptimal plan", "%"),
                ("replans", "re-plans", ""),
                ("messages", "messages", ""),
                ("bytes", "bytes", ""),
                ("expansions", "expansions", ""),
                ("failed moves", "failed moves", ""),
            ],
        ),
        "",
        "By map kind (all settings pooled):",
        "",
        table(
            result["by_kind"],
            [
                ("kind", "map kind", ""),
                ("policy", "policy", ""),
                ("episodes", "episodes", "int"),
                ("success", "success", "%"),
                ("meeting time (s)", "meeting time (s)", ""),
                ("meeting time / centralized", "vs centralized", "ratio"),
                ("worst optimality max", "worst optimality max", "ratio"),
                ("suboptimal plan", "episodes with a suboptimal plan", "%"),
                ("replans", "re-plans", ""),
                ("bytes", "bytes", ""),
            ],
        ),
        "",
    ]
    if result["failed"]:
        text += [f"**{len(result['failed'])} episode(s) did not meet:**", ""] + [
            f"* {json.dumps({k: v for k, v in f.items() if k != 'config'})}" for f in result["failed"][:50]
        ]
    else:
        text.append("Every episode met.")
    return "\n".join(text) + "\n"


# -- CLI -------------------------------------------------------------------------------------------------
def _write(out: Path, name: str, result: dict[str, Any], markdown: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    write_summary_json(out / f"{name}.json", result)
    (out / f"{name}.md").write_text(markdown)


def _loud(message: str) -> None:
    bar = "!" * 80
    print(f"\n{bar}\n{message}\n{bar}\n", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run a subcommand; returns the exit code (1 when a check failed)."""
    parser = argparse.ArgumentParser(description="Paper 003: planner sweep over random maps and Rendezvous-v0 episodes.")
    parser.add_argument("experiment", choices=["planners", "episodes"])
    parser.add_argument("--out", type=Path, default=Path("results/paper003"))
    parser.add_argument("--maps", type=int, default=1000, help="planners: random maps (default 1000)")
    parser.add_argument("--replans", type=int, default=2, help="planners: re-planning queries per map (default 2)")
    parser.add_argument("--seeds", type=int, default=100, help="episodes: maps = episodes per setting and policy (default 100)")
    parser.add_argument("--places", type=int, nargs=2, default=None, metavar=("MIN", "MAX"), help="map sizes (places)")
    parser.add_argument("--seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    args = parser.parse_args(argv)
    if args.experiment == "planners":
        result = planner_sweep(args.maps, args.seed, tuple(args.places or (20, 10_000)), args.replans, args.workers)
        markdown = planners_markdown(result)
        _write(args.out, "planners", result, markdown)
        print(markdown, flush=True)
        if result["failures"]:
            _loud(f"FAILURE: {len(result['failures'])} planner check(s) failed, e.g. {result['failures'][0]}")
            return 1
        return 0
    result = episode_runs(args.seeds, args.seed, tuple(args.places or (20, 200)), args.workers, args.out)
    markdown = episodes_markdown(result)
    _write(args.out, "episodes", result, markdown)
    print(markdown, flush=True)
    if result["failed"]:
        errors = sum(1 for f in result["failed"] if f.get("error"))
        _loud(
            f"{len(result['failed'])} episode(s) did not meet ({errors} raised an exception); "
            f"see {args.out / 'episodes.json'} ('failed': settings, error, env config)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
