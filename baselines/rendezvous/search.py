"""Rendezvous planners of paper 003 (section 4) and the meeting place (section 3, Steps 4 and 8).

Every planner works on an undirected ``networkx.Graph`` whose nodes carry ``pos`` (x, y) and
whose edges carry ``length`` (as :meth:`teamgym.maps.graph.GraphMap.to_networkx` builds), with
a collection of *blocked* ways (frozensets or pairs of two nodes, or ``Way`` objects) treated
as removed. The heuristic is the Euclidean distance between ``pos``: admissible and consistent
because a way is never shorter than the straight line (:class:`SearchGraph` checks it).

Planners (``PLANNERS`` maps their names to them), each returning a :class:`PlanResult`:

* :func:`astar` (``astar``) -- unidirectional A* from robot A's place to robot B's.
* :func:`distributed_bidirectional_astar` (``bidir-astar``) -- the paper's protocol, faithfully:
  two lockstep A* searches that stop when Agent 1's chosen node lies on Agent 2's current path.
  Not always optimal (that is the paper's rule, kept on purpose).
* :func:`bidirectional_astar_optimal` (``bidir-astar-opt``) -- the same two-agent structure with
  a provably optimal stopping rule (bidirectional A* with average potentials).
* :func:`centralized_shortest_path` (``centralized``) -- networkx Dijkstra, the reference.

Tie-breaking (deterministic): an open list is a binary heap of tuples ending in the node's
index in the graph's node order. :func:`astar` and both agents of the paper's protocol use
``(f, h, index)``: among equal ``f`` the node with the smaller ``h`` (the deeper one) first,
then the node that comes first in the graph's node order; :func:`bidirectional_astar_optimal`
uses ``(key, index)``. Neighbours are relaxed in the graph's adjacency order. A graph with the
same node and adjacency order and the same query always give the same result (the order in
which blocked ways are listed does not matter).

Messages (what the distributed protocol would exchange, section 4 and section 5's message
types): Agent 2 sends its current path after each of its iterations, Agent 1 sends the whole
path at the end; ``message_places`` totals the place ids carried. A single-agent planner
(:func:`astar`, :func:`centralized_shortest_path`) counts the one whole-path message to the
partner. A failed search sends no whole path.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from heapq import heappop, heappush

import networkx as nx

__all__ = [
    "PLANNERS",
    "MeetingPlace",
    "PlanResult",
    "SearchGraph",
    "astar",
    "bidirectional_astar_optimal",
    "centralized_shortest_path",
    "distributed_bidirectional_astar",
    "meeting_place",
]

Node = Hashable
Blocked = Iterable[Iterable[Node]]
LENGTH_TOLERANCE = 1e-9
"""A way may be shorter than the straight line by this much (relative, at least 1e-9 m), as in graph maps."""

_INF = math.inf
_NO_CUT: frozenset[int] = frozenset()


@dataclass(frozen=True)
class PlanResult:
    """A planner's answer for the rendezvous of robots A and B.

    ``path``: places from A's place to B's place, or None if B cannot be reached (``cost`` is
    then ``inf``). ``expansions``: nodes taken from the open lists (stale heap entries not
    counted), None where not counted (networkx); ``expansions_per_agent``: the same per agent
    (Agent 1, Agent 2). ``meeting_node``: where the two half-searches joined (None for a
    one-sided search). ``messages`` / ``message_places``: see the module docstring.
    """

    path: list[Node] | None
    cost: float
    expansions: int | None
    expansions_per_agent: tuple[int, ...]
    meeting_node: Node | None
    messages: int
    message_places: int

    @property
    def found(self) -> bool:
        """Whether a path was found."""
        return self.path is not None


# -- the prepared graph ------------------------------------------------------------------


_CACHE: weakref.WeakKeyDictionary[nx.Graph, SearchGraph] = weakref.WeakKeyDictionary()


class SearchGraph:
    """A ``networkx.Graph`` prepared for search: integer node indices, coordinates, adjacency lists.

    Built once per graph and cached by :meth:`of` (every planner calls it, so passing the same
    graph again costs nothing). The cache notices nodes added or removed; after changing
    ``pos``, ``length`` or the ways of a cached graph in place, call ``SearchGraph.of(graph,
    refresh=True)``. Blocked ways are per query and never need a rebuild.
    """

    __slots__ = ("nodes", "index", "n", "xs", "ys", "adj", "_ways", "__weakref__")

    def __init__(self, graph: nx.Graph) -> None:
        if not isinstance(graph, nx.Graph) or graph.is_directed() or graph.is_multigraph():
            raise TypeError(f"expected an undirected networkx.Graph (not multi), got {type(graph).__name__}")
        self.nodes: list[Node] = list(graph)
        self.n = len(self.nodes)
        self.index: dict[Node, int] = {v: i for i, v in enumerate(self.nodes)}
        self.xs, self.ys = _coordinates(graph, self.nodes)
        self.adj, self._ways = self._adjacency(graph)

    @classmethod
    def of(cls, graph: nx.Graph | SearchGraph, *, refresh: bool = False) -> SearchGraph:
        """The cached :class:`SearchGraph` of ``graph`` (built on first use or when ``refresh``)."""
        if isinstance(graph, SearchGraph):
            return graph
        prepared = None if refresh else _CACHE.get(graph)
        if prepared is None or prepared.n != len(graph):
            prepared = cls(graph)
            _CACHE[graph] = prepared
        return prepared

    def _adjacency(self, graph: nx.Graph) -> tuple[list[tuple[tuple[int, float], ...]], set[int]]:
        index, n, xs, ys = self.index, self.n, self.xs, self.ys
        adj, ways = [], set()
        for u in self.nodes:
            i, row = index[u], []
            for v, data in graph.adj[u].items():
                j = index[v]
                if i != j:  # a loop never shortens a path
                    row.append((j, _way_length(u, v, data, math.hypot(xs[i] - xs[j], ys[i] - ys[j]))))
                    ways.add(i * n + j)
            adj.append(tuple(row))
        return adj, ways

    def node_index(self, node: Node) -> int:
        """Index of ``node``; KeyError naming it if the graph has no such node."""
        try:
            return self.index[node]
        except (KeyError, TypeError):
            raise KeyError(f"the graph has no place {node!r}") from None

    def cut(self, blocked: Blocked | None) -> frozenset[int] | set[int]:
        """Codes ``i * n + j`` (both directions) of the ``blocked`` ways; KeyError for a pair that is no way."""
        index, ways, n = self.index, self._ways, self.n
        codes: set[int] = set()
        add = codes.add
        for way in blocked or ():
            try:
                p, q = way
                i, j = index[p], index[q]
            except (KeyError, TypeError, ValueError):
                p, q = self._ends(way)
                i, j = index[p], index[q]
            if i * n + j not in ways:
                raise KeyError(f"the graph has no way between {p!r} and {q!r} to block")
            add(i * n + j)
            add(j * n + i)
        return codes or _NO_CUT

    def _ends(self, way: object) -> tuple[Node, Node]:
        """The two known places of a blocked way given as a pair, a frozenset or a ``Way``-like object (``.ends``)."""
        try:
            ends = tuple(getattr(way, "ends", way))
        except TypeError:
            raise TypeError(f"a blocked way must be a pair of places, got {way!r}") from None
        if len(ends) != 2:
            raise TypeError(f"a blocked way must have two ends, got {way!r}")
        for end in ends:
            self.node_index(end)
        return ends

    def names(self, indices: Iterable[int]) -> list[Node]:
        """The nodes with the given indices."""
        nodes = self.nodes
        return [nodes[i] for i in indices]


def _coordinates(graph: nx.Graph, nodes: list[Node]) -> tuple[list[float], list[float]]:
    xs, ys = [], []
    for v in nodes:
        pos = graph.nodes[v].get("pos")
        if pos is None:
            raise KeyError(f"place {v!r} has no 'pos' attribute (x, y)")
        x, y = (float(c) for c in pos)
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"place {v!r}: pos {tuple(pos)!r} is not finite")
        xs.append(x)
        ys.append(y)
    return xs, ys


def _way_length(u: Node, v: Node, data: Mapping, straight: float) -> float:
    if "length" not in data:
        raise KeyError(f"way ({u!r}, {v!r}) has no 'length' attribute")
    length = float(data["length"])
    if not math.isfinite(length) or length < straight - LENGTH_TOLERANCE * max(1.0, straight):
        raise ValueError(
            f"way ({u!r}, {v!r}): length {length!r} is not finite or is shorter than the straight line "
            f"({straight:.9g}); the Euclidean heuristic would not be admissible"
        )
    return length


def _unreachable(expansions: tuple[int, ...], messages: int = 0, places: int = 0) -> PlanResult:
    return PlanResult(None, _INF, sum(expansions), expansions, None, messages, places)


# -- A* (one agent's search) ---------------------------------------------------------------


class _AStar:
    """One agent's A* from ``root`` toward ``target``: heap of ``(f, h, index)``, g, parents, depths."""

    __slots__ = ("adj", "xs", "ys", "n", "tx", "ty", "cut", "g", "parent", "depth", "closed", "heap", "expansions")

    def __init__(self, sg: SearchGraph, root: int, target: int, cut: frozenset[int] | set[int]) -> None:
        self.adj, self.xs, self.ys, self.n, self.cut = sg.adj, sg.xs, sg.ys, sg.n, cut
        self.tx, self.ty = sg.xs[target], sg.ys[target]
        self.g = [_INF] * sg.n
        self.parent = [-1] * sg.n
        self.depth = [0] * sg.n
        self.closed = bytearray(sg.n)
        self.g[root] = 0.0
        h = math.hypot(sg.xs[root] - self.tx, sg.ys[root] - self.ty)
        self.heap = [(h, h, root)]
        self.expansions = 0

    def choose(self) -> int:
        """Take the best open node (paper: "choose a successor node"), close it; -1 if the open list is empty."""
        heap, closed = self.heap, self.closed
        while heap:
            u = heappop(heap)[2]
            if not closed[u]:
                closed[u] = 1
                self.expansions += 1
                return u
        return -1

    def expand(self, u: int) -> None:
        """Label the open neighbours of ``u`` reached more cheaply through it (blocked ways skipped)."""
        xs, ys, tx, ty, g, parent, depth, closed, heap, cut = (
            self.xs, self.ys, self.tx, self.ty, self.g, self.parent, self.depth, self.closed, self.heap, self.cut
        )  # fmt: skip
        base, gu, du = u * self.n, g[u], self.depth[u] + 1
        for v, w in self.adj[u]:
            if closed[v] or (cut and base + v in cut):
                continue
            ng = gu + w
            if ng < g[v]:
                g[v], parent[v], depth[v] = ng, u, du
                h = math.hypot(xs[v] - tx, ys[v] - ty)
                heappush(heap, (ng + h, h, v))

    def chain(self, v: int) -> list[int]:
        """Indices of the current path (parent chain) from the root to ``v``."""
        return _chain(self.parent, v)

    def on_chain(self, v: int, tip: int) -> bool:
        """Whether ``v`` lies on the current path from the root to the closed node ``tip``."""
        if not self.closed[v]:
            return False
        parent = self.parent
        for _ in range(self.depth[tip] - self.depth[v]):
            tip = parent[tip]
        return tip == v


def _chain(parent: list[int], v: int) -> list[int]:
    out = [v]
    while parent[v] >= 0:
        v = parent[v]
        out.append(v)
    out.reverse()
    return out


def astar(graph: nx.Graph | SearchGraph, start: Node, goal: Node, blocked: Blocked | None = ()) -> PlanResult:
    """Unidirectional A* from ``start`` to ``goal`` (the "typical A*" of section 4), Euclidean heuristic.

    Stops when ``goal`` is taken from the open list (counted as an expansion). Ties: see the module docstring.
    """
    sg = SearchGraph.of(graph)
    s, t = sg.node_index(start), sg.node_index(goal)
    search = _AStar(sg, s, t, sg.cut(blocked))
    while (u := search.choose()) != t:
        if u < 0:
            return _unreachable((search.expansions,))
        search.expand(u)
    path = sg.names(search.chain(t))
    return PlanResult(path, search.g[t], search.expansions, (search.expansions,), None, 1, len(path))


# -- the paper's distributed bidirectional A* ---------------------------------------------------------------


def distributed_bidirectional_astar(graph: nx.Graph | SearchGraph, a: Node, b: Node, blocked: Blocked | None = ()) -> PlanResult:
    """The distributed bidirectional A* of section 4 (Agent 1 from ``a`` toward ``b``, Agent 2 from ``b`` toward ``a``).

    Lockstep, one choice per agent per iteration: Agent 2 chooses ``P2`` (its steps 1-2),
    expands it and sends its current path (root ``b`` .. ``P2``); then Agent 1 chooses ``P1``
    (steps 1-2) and tests ``P1`` against that path (steps 3-4). Only Agent 1 tests: the text
    gives Agent 2 no test, so the symmetric condition is not checked. On ``P1 ∈ Path2`` the
    whole path is Agent 1's path ``a .. P1`` plus Agent 2's path from ``P1`` back to ``b``, and
    Agent 1 sends it. Once Agent 2 chooses its goal ``a`` its A* is complete: it keeps that path
    and sends nothing more while Agent 1 goes on. Either open list emptying means unreachable.
    The rule stops at the first meeting, not at a proven optimum: the cost may exceed the
    shortest path's (kept on purpose). Section 5 words the end as "a coincidence between two
    positions" of the agents' belief sets; section 4's ``P1 ∈ Path2`` is used here.
    """
    sg = SearchGraph.of(graph)
    s, t = sg.node_index(a), sg.node_index(b)
    cut = sg.cut(blocked)
    agent1, agent2 = _AStar(sg, s, t, cut), _AStar(sg, t, s, cut)
    messages = places = 0
    p2, agent2_done = -1, False
    while True:
        if not agent2_done:
            p2 = agent2.choose()
            if p2 < 0:
                return _unreachable((agent1.expansions, agent2.expansions), messages, places)
            messages, places = messages + 1, places + agent2.depth[p2] + 1
            agent2_done = p2 == s
            if not agent2_done:
                agent2.expand(p2)
        p1 = agent1.choose()
        if p1 < 0:
            return _unreachable((agent1.expansions, agent2.expansions), messages, places)
        if agent2.on_chain(p1, p2):
            break
        agent1.expand(p1)
    path = sg.names(agent1.chain(p1)[:-1] + _chain(agent2.parent, p1)[::-1])
    counts = (agent1.expansions, agent2.expansions)
    cost = agent1.g[p1] + agent2.g[p1]
    return PlanResult(path, cost, sum(counts), counts, sg.nodes[p1], messages + 1, places + len(path))


# -- optimal bidirectional A* -----------------------------------------------------------------------


def bidirectional_astar_optimal(graph: nx.Graph | SearchGraph, a: Node, b: Node, blocked: Blocked | None = ()) -> PlanResult:
    """Bidirectional A* with average potentials and a provably optimal stop (``bidir-astar-opt``).

    Criterion: the "average potential" (consistent average) bidirectional A* of Ikeda et al.
    (1994) as used by Goldberg and Harrelson (2005). With ``h_a``, ``h_b`` the Euclidean
    distances to ``a`` and ``b`` and ``p(v) = (h_b(v) - h_a(v)) / 2``, Agent 1 orders its open
    list by ``k1 = g1 + p`` and Agent 2 by ``k2 = g2 - p``: both are Dijkstra's algorithm on the
    same non-negative reduced lengths, so the bidirectional-Dijkstra stop applies: finish when
    ``min k1 + min k2 >= mu``, ``mu`` being the best whole path ``g1 + g2`` through a node
    labelled by both agents. Agent 1 also skips labels with ``g1 + h_b >= mu`` (they cannot
    beat ``mu``).

    Two-agent structure as in :func:`distributed_bidirectional_astar`: per lockstep iteration
    Agent 2 closes one node and sends its current path with its ``min k2``; Agent 1 tests the
    stop, closes one node and tests again (so the test precedes every expansion); at the end
    Agent 1 sends the whole path. Agent 1 knows Agent 2's labels without further messages:
    they follow from the received paths (exact ``g2`` of the closed nodes), the shared map
    and the blocked ways. Ties: smaller key, then the node first in the graph's order.
    """
    sg = SearchGraph.of(graph)
    s, t = sg.node_index(a), sg.node_index(b)
    mu, meet, parents, counts, messages, places = _average_potential_search(sg, s, t, sg.cut(blocked))
    if meet < 0:
        return _unreachable(counts, messages, places)
    path = sg.names(_chain(parents[0], meet)[:-1] + _chain(parents[1], meet)[::-1])
    return PlanResult(path, mu, sum(counts), counts, sg.nodes[meet], messages + 1, places + len(path))


def _average_potential_search(sg: SearchGraph, s: int, t: int, cut: frozenset[int] | set[int]) -> tuple:
    """The lockstep loop of :func:`bidirectional_astar_optimal`, written flat for speed.

    Returns ``(mu, meeting index or -1, (parents1, parents2), (expansions1, expansions2), messages, places)``.
    """
    adj, xs, ys, n = sg.adj, sg.xs, sg.ys, sg.n
    hypot = math.hypot
    ax, ay, bx, by = xs[s], ys[s], xs[t], ys[t]
    g1, g2 = [_INF] * n, [_INF] * n
    par1, par2 = [-1] * n, [-1] * n
    depth2 = [0] * n
    closed1, closed2 = bytearray(n), bytearray(n)
    half = 0.5 * hypot(ax - bx, ay - by)
    g1[s] = g2[t] = 0.0
    heap1, heap2 = [(half, s)], [(half, t)]
    mu, meet = (0.0, s) if s == t else (_INF, -1)
    n1 = n2 = messages = places = 0
    top1 = top2 = half
    while True:
        # Agent 1 tests the stop (after its own step, on Agent 2's last message) before Agent 2 goes on,
        # and again after Agent 2's step: the test is made before every expansion.
        if top1 + top2 >= mu:
            break
        # Agent 2: close its best open node, expand it, send the path to it (with g2) and its min key.
        u = heappop(heap2)[1]
        closed2[u] = 1
        n2 += 1
        gu, du, base = g2[u], depth2[u] + 1, u * n
        messages, places = messages + 1, places + du
        for v, w in adj[u]:
            if closed2[v] or (cut and base + v in cut):
                continue
            ng = gu + w
            if ng < g2[v]:
                g2[v], par2[v], depth2[v] = ng, u, du
                if ng + g1[v] < mu:
                    mu, meet = ng + g1[v], v
                x, y = xs[v], ys[v]
                heappush(heap2, (ng + 0.5 * (hypot(x - ax, y - ay) - hypot(x - bx, y - by)), v))
        top2 = _top(heap2, closed2)
        if top1 + top2 >= mu:
            break
        # Agent 1: close its best open node and expand it; labels that cannot beat mu are skipped.
        u = heappop(heap1)[1]
        closed1[u] = 1
        n1 += 1
        gu, base = g1[u], u * n
        for v, w in adj[u]:
            if closed1[v] or (cut and base + v in cut):
                continue
            ng = gu + w
            if ng < g1[v]:
                g1[v], par1[v] = ng, u
                if ng + g2[v] < mu:
                    mu, meet = ng + g2[v], v
                x, y = xs[v], ys[v]
                hb = hypot(x - bx, y - by)
                if ng + hb < mu:
                    heappush(heap1, (ng + 0.5 * (hb - hypot(x - ax, y - ay)), v))
        top1 = _top(heap1, closed1)
    return mu, meet, (par1, par2), (n1, n2), messages, places


def _top(heap: list[tuple[float, int]], closed: bytearray) -> float:
    """The smallest key of the open list (stale entries of closed nodes dropped); inf if it is empty."""
    while heap and closed[heap[0][1]]:
        heappop(heap)
    return heap[0][0] if heap else _INF


# -- centralized reference ---------------------------------------------------------------------


def centralized_shortest_path(graph: nx.Graph, a: Node, b: Node, blocked: Blocked | None = ()) -> PlanResult:
    """networkx Dijkstra on ``length`` with ``blocked`` ways hidden: the reference (expansions not counted)."""
    sg = SearchGraph.of(graph)
    sg.node_index(a)
    sg.node_index(b)
    blocked = list(blocked or ())
    sg.cut(blocked)  # validates the blocked ways
    cut = {frozenset(getattr(way, "ends", way)) for way in blocked}

    def length(u: Node, v: Node, data: dict) -> float | None:
        return None if cut and frozenset((u, v)) in cut else data["length"]  # None hides the way

    try:
        cost, path = nx.single_source_dijkstra(graph, a, b, weight=length)
    except nx.NetworkXNoPath:
        return PlanResult(None, _INF, None, (), None, 0, 0)
    return PlanResult(path, float(cost), None, (), None, 1, len(path))


PLANNERS: dict[str, Callable[..., PlanResult]] = {
    "astar": astar,
    "bidir-astar": distributed_bidirectional_astar,
    "bidir-astar-opt": bidirectional_astar_optimal,
    "centralized": centralized_shortest_path,
}
"""The planners by name: ``planner(graph, a, b, blocked)`` -> :class:`PlanResult`."""


# -- meeting place -------------------------------------------------------------------------------


@dataclass(frozen=True)
class MeetingPlace:
    """Where two robots moving toward each other along a path meet first (section 3, Steps 4 and 8).

    ``node`` (at ``index`` in the path) minimises ``max(time_a, time_b)``, reached by both at
    ``time`` (s). Off the nodes they would meet earlier, at ``way_time = L / (v_a + v_b)``,
    after robot A covered ``distance_a`` (m): on ``way`` = (path[k], path[k + 1]) at
    ``fraction`` of its length from path[k], or exactly on a node (``way`` None, ``fraction`` 0).
    """

    node: Node
    index: int
    time: float
    way: tuple[Node, Node] | None
    fraction: float
    way_time: float
    distance_a: float


def meeting_place(
    path: Sequence[Node],
    speeds: tuple[float, float] = (1.0, 1.0),
    *,
    graph: nx.Graph | SearchGraph | None = None,
    positions: Mapping[Node, Sequence[float]] | None = None,
    lengths: Sequence[float] | None = None,
) -> MeetingPlace:
    """The earliest meeting place of robots A (at ``path[0]``) and B (at ``path[-1]``) along ``path``.

    Section 3: the robots "meet as soon as possible" and "can have different speeds" (Steps 4
    and 8 detect the meeting on the way). Robot A moves at ``speeds[0]``, B at ``speeds[1]``
    (m/s, >= 0, not both 0). Way lengths come from exactly one of ``graph`` (edge ``length``),
    ``positions`` (straight lines between place coordinates) or ``lengths`` (one per way).
    Equal speeds give the node nearest the middle by cost; with ``v_a = 2 v_b`` robot B covers
    a third. Among nodes with equal times the one nearer A (lower index) is chosen.
    """
    va, vb = _check_speeds(speeds)
    cum = _cumulative(_way_lengths(path, graph, positions, lengths))
    total = cum[-1]
    times = [max(_travel(c, va), _travel(total - c, vb)) for c in cum]
    index = min(range(len(cum)), key=times.__getitem__)
    distance_a = total * va / (va + vb)
    k, fraction = _locate(cum, distance_a)
    way = None if fraction == 0.0 else (path[k], path[k + 1])
    return MeetingPlace(path[index], index, times[index], way, fraction, total / (va + vb), distance_a)


def _check_speeds(speeds: tuple[float, float]) -> tuple[float, float]:
    try:
        va, vb = (float(v) for v in speeds)
    except (TypeError, ValueError):
        raise TypeError(f"speeds must be a pair of numbers (v_a, v_b), got {speeds!r}") from None
    if not (math.isfinite(va) and math.isfinite(vb) and va >= 0 and vb >= 0 and va + vb > 0):
        raise ValueError(f"speeds must be finite, >= 0 and not both 0, got {speeds!r}")
    return va, vb


def _way_lengths(
    path: Sequence[Node],
    graph: nx.Graph | SearchGraph | None,
    positions: Mapping[Node, Sequence[float]] | None,
    lengths: Sequence[float] | None,
) -> list[float]:
    if len(path) == 0:
        raise ValueError("the path is empty")
    if sum(x is not None for x in (graph, positions, lengths)) != 1:
        raise TypeError("give exactly one of graph, positions or lengths")
    if lengths is not None:
        out = [float(x) for x in lengths]
        if len(out) != len(path) - 1:
            raise ValueError(f"{len(path)} places need {len(path) - 1} way lengths, got {len(out)}")
    elif positions is not None:
        out = [math.dist(positions[p], positions[q]) for p, q in zip(path, path[1:])]
    else:
        out = _graph_lengths(SearchGraph.of(graph), path)
    if not all(math.isfinite(x) and x >= 0 for x in out):
        raise ValueError(f"way lengths must be finite and >= 0, got {out}")
    return out


def _graph_lengths(sg: SearchGraph, path: Sequence[Node]) -> list[float]:
    out = []
    for p, q in zip(path, path[1:]):
        j = sg.node_index(q)
        length = next((w for v, w in sg.adj[sg.node_index(p)] if v == j), None)
        if length is None:
            raise KeyError(f"the graph has no way between {p!r} and {q!r}")
        out.append(length)
    return out


def _cumulative(lengths: list[float]) -> list[float]:
    cum = [0.0]
    for length in lengths:
        cum.append(cum[-1] + length)
    return cum


def _travel(distance: float, speed: float) -> float:
    if distance <= 0.0:
        return 0.0
    return distance / speed if speed > 0 else _INF


def _locate(cum: list[float], distance: float) -> tuple[int, float]:
    """``(k, fraction)`` with ``distance`` on way k at ``fraction``; fraction 0 when it is on node k."""
    tol = 1e-12 * max(1.0, cum[-1])
    for k, c in enumerate(cum):
        if abs(distance - c) <= tol:
            return k, 0.0
        if k + 1 < len(cum) and c < distance < cum[k + 1]:
            return k, (distance - c) / (cum[k + 1] - c)
    return len(cum) - 1, 0.0
