"""The topological layer of the world model: the weighted graph M = (V, W) of eq. (1).

Vertices are the sectors V_S and the door objects V_D; edges join a door to its two sectors
and two sectors joined by an open passage (corridor parts). Edge weights are transition
costs built from the distances of eq. (4),

    L_ij = sqrt((x_i^p − x_j^p)² + (y_i^p − y_j^p)²),                      (4)

and from the clutter c_i of sectors and the opening probability o_j of doors. Eq. (3) (three
cost formulas, one per pair of object types) is lost in the paper's text. Our reading,
consistent with eq. (2) (a sector of clutter c makes a robot travel 1 / (1 − c) times the
straight distance on average) and with o_j as the chance of finding the door open (so
1 / o_j expected attempts)::

    w(S_i, D_j) = w(D_j, S_i) = L_ij / ((1 − c_i) · o_j)                   (3a, 3b)
    w(S_i, S_k)               = ½ L_ik · (1 / (1 − c_i) + 1 / (1 − c_k))    (3c)

Costs grow with L and c, grow as o falls, and are infinite for a door known to be closed
(o_j = 0). That is the default reading ``door_reading="per-attempt"``: 1 / o_j attempts, each
costing the way to the door. The second reading, ``"return-trip"``, charges every failed
attempt the way back as well (the robot that finds the door closed returns, L, and comes again,
L): 1 + 2 (1 − o_j) / o_j trips, i.e.

    w(S_i, D_j) = w(D_j, S_i) = L_ij (2 − o_j) / ((1 − c_i) · o_j)          (3a, 3b; "return-trip")

Both equal L / (1 − c) for a door that is always open; for o = 0.2 (the paper's D3,6, "closed
most of the time", "almost for sure closed", section 5.3) the door costs 5 L in the first
reading and 9 L in the second. Only the second keeps robot 1 of Table 1 off D3,6
(experiments/paper000_exploration.py ``table1``; docs/exploration.md).

Eq. (2) is also lost; we read it as c_i = 1 − (1/K) Σ_k d_k,0 / d_k,T (0 for an empty sector,
→ 1 when the travelled distance d_T grows without bound), with the designer's
initial value counted as ``prior_weight`` earlier observations (:class:`ClutterEstimate`).
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np

from teamgym.maps.model import OfficeMap


def characteristic_distance(a: tuple[float, float], b: tuple[float, float]) -> float:
    """L_ij of eq. (4) between two characteristic (centre) points, in metres."""
    return math.hypot(a[0] - b[0], a[1] - b[1])


#: The readings of eqs. (3a)/(3b) (module docstring): the first is the default everywhere.
DOOR_READINGS = ("per-attempt", "return-trip")


def check_door_reading(reading: str) -> str:
    """Return ``reading`` if it is one of :data:`DOOR_READINGS`, else raise a one-line ValueError."""
    if reading not in DOOR_READINGS:
        raise ValueError(f"door_reading must be one of {DOOR_READINGS}, got {reading!r}")
    return reading


def door_cost(length: float, clutter: float, open_probability: float, reading: str = "per-attempt") -> float:
    """w(S_i, D_j) of eqs. (3a)/(3b) as read here; inf if o_j = 0 or c_i = 1.

    ``"per-attempt"``: L / ((1 − c_i) o_j); ``"return-trip"``: L (2 − o_j) / ((1 − c_i) o_j).
    """
    check_door_reading(reading)
    if open_probability <= 0.0 or clutter >= 1.0:
        return math.inf
    trips = 1.0 if reading == "per-attempt" else 2.0 - open_probability
    return length * trips / ((1.0 - clutter) * open_probability)


def passage_cost(length: float, clutter_a: float, clutter_b: float) -> float:
    """w(S_i, S_k) = ½ L (1/(1 − c_i) + 1/(1 − c_k)), eq. (3c) as read here."""
    if clutter_a >= 1.0 or clutter_b >= 1.0:
        return math.inf
    return 0.5 * length * (1.0 / (1.0 - clutter_a) + 1.0 / (1.0 - clutter_b))


def shortest_costs(weights: np.ndarray) -> np.ndarray:
    """All-pairs minimal path costs (Floyd–Warshall) of a cost matrix with ``inf`` for no edge."""
    d = np.array(weights, dtype=float)
    np.fill_diagonal(d, 0.0)
    for k in range(len(d)):
        np.minimum(d, d[:, k : k + 1] + d[k : k + 1, :], out=d)
    return d


class ClutterEstimate:
    """Clutter coefficients re-estimated from executed tasks, eq. (2) as read here.

    ``c_i = 1 − (K0 (1 − c_i⁰) + Σ_k r_k) / (K0 + K)`` with r_k = d_k,0 / d_k,T ∈ (0, 1] the
    ratio of straight-line to travelled distance of the k-th task in sector i, c_i⁰ the
    designer's value and K0 = ``prior_weight``.
    """

    def __init__(self, prior: np.ndarray, prior_weight: float = 5.0) -> None:
        if prior_weight <= 0:
            raise ValueError(f"prior_weight must be > 0, got {prior_weight}")
        self.prior = np.asarray(prior, dtype=float).copy()
        self.prior_weight = float(prior_weight)
        self.ratio_sum = np.zeros_like(self.prior)
        self.count = np.zeros_like(self.prior)

    def observe(self, sector: int, straight: float, travelled: float) -> None:
        """Record one navigational task of sector index ``sector``: straight and travelled distance (m)."""
        if not (straight > 0 and travelled > 0 and math.isfinite(straight) and math.isfinite(travelled)):
            return
        self.ratio_sum[sector] += min(1.0, straight / travelled)
        self.count[sector] += 1

    @property
    def values(self) -> np.ndarray:
        k0 = self.prior_weight
        return 1.0 - (k0 * (1.0 - self.prior) + self.ratio_sum) / (k0 + self.count)


class TopologicalModel:
    """The graph of eq. (1) with current clutter and door-opening beliefs; costs by eq. (3).

    ``clutter`` (one per sector) and ``door_open`` (one per door, o_j) are arrays the owner
    may update (e.g. o_j = 0 once a door is seen closed); every cost query reads them.
    Vertex ``k`` is ``vertices[k]``: sectors first, then doors. ``door_reading`` is the reading of
    eqs. (3a)/(3b), one of :data:`DOOR_READINGS` (module docstring).
    """

    def __init__(self, office: OfficeMap, door_reading: str = "per-attempt") -> None:
        self.door_reading = check_door_reading(door_reading)
        self.map = office
        self.vertices = office.vertex_ids
        self.index = {v: k for k, v in enumerate(self.vertices)}
        self.n_sectors = len(office.sectors)
        self.clutter = np.array([s.clutter for s in office.sectors], dtype=float)
        self.door_open = np.array([d.open_probability for d in office.doors], dtype=float)
        self.points = np.array([s.centre for s in office.sectors] + [d.centre for d in office.doors], dtype=float)
        graph = nx.Graph()
        for s in office.sectors:
            graph.add_node(s.id, kind="sector", centre=s.centre)
        for d in office.doors:
            graph.add_node(d.id, kind="door", centre=d.centre, radius=d.radius)
            for sid in d.sectors:
                graph.add_edge(sid, d.id, length=characteristic_distance(office.sector(sid).centre, d.centre))
        for a, b in office.passages:
            graph.add_edge(a, b, length=characteristic_distance(office.sector(a).centre, office.sector(b).centre))
        self.graph = graph
        self._edges = [(self.index[a], self.index[b], data["length"]) for a, b, data in graph.edges(data=True)]

    def is_sector(self, k: int) -> bool:
        return k < self.n_sectors

    def cost(self, a: int, b: int) -> float:
        """w(a, b) of eq. (3) between adjacent vertex indices (inf if not adjacent)."""
        if a == b:
            return 0.0
        u, v = self.vertices[a], self.vertices[b]
        if not self.graph.has_edge(u, v):
            return math.inf
        length = self.graph.edges[u, v]["length"]
        return self._edge_cost(a, b, length)

    def _edge_cost(self, a: int, b: int, length: float) -> float:
        n = self.n_sectors
        if a < n and b < n:
            return passage_cost(length, self.clutter[a], self.clutter[b])
        sector, door = (a, b - n) if a < n else (b, a - n)
        return door_cost(length, self.clutter[sector], self.door_open[door], self.door_reading)

    def cost_matrix(self) -> np.ndarray:
        """Matrix of w for every pair of vertex indices (0 on the diagonal, inf off the graph)."""
        w = np.full((len(self.vertices), len(self.vertices)), np.inf)
        np.fill_diagonal(w, 0.0)
        for a, b, length in self._edges:
            w[a, b] = w[b, a] = self._edge_cost(a, b, length)
        return w

    def path_costs(self) -> np.ndarray:
        """Minimal path costs between all vertex pairs (the cost of p_min of eq. 10)."""
        return shortest_costs(self.cost_matrix())

    def weighted_graph(self) -> nx.Graph:
        """A copy of the graph with the current costs as ``weight`` (edges of infinite cost left out)."""
        graph = nx.Graph()
        graph.add_nodes_from(self.graph.nodes(data=True))
        for a, b, length in self._edges:
            w = self._edge_cost(a, b, length)
            if math.isfinite(w):
                graph.add_edge(self.vertices[a], self.vertices[b], weight=w, length=length)
        return graph

    def shortest_path(self, source: str, target: str) -> list[str]:
        """p_min(source, target) of eq. (10) as a list of vertex ids (raises if unreachable)."""
        return nx.dijkstra_path(self.weighted_graph(), source, target, weight="weight")
