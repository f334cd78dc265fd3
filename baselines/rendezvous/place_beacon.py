"""A rendezvous policy that talks through the learned-message channel (``comm_dim``): ``place-beacon``.

Paper 003's protocol exchanges whole plans as integer records (``protocol_messages=True``).
This policy speaks the channel a learned team has instead -- ``comm_dim = 3`` values in
[-1, 1] per robot and step (kind ``"learned"``, through the env's channel with its range, loss
and latency) -- so that it can teach a learned policy what to send and how to read it
(behaviour cloning, docs/training.md). It is decentralised: each robot reads only its own
observation (place, target, neighbours, blocked flags, inbox).

* **Message** -- the place the robot is going to (its next place, or its place while it
  waits) and a flag: 1 once it has heard its mate, -1 before. A place is sent as a cell of a
  ``levels`` × ``levels`` grid over the map (the grid of a discrete learned message with
  ``--message-levels``): each place takes the free cell nearest its position, places in index
  order, so every place has a cell of its own and nearby places have nearby cells
  (:func:`grid_codes`). A heard message names the place of the nearest cell.
* **Memory** -- the mate's last heard place and flag (the channel loses messages,
  ``comm_throughput``) and the ways the robot has found blocked (its ``blocked`` flags).
* **Motion** -- until it has heard its mate the robot waits, and it waits ``ack_stages`` more
  stages while the mate's flag says the mate has not heard it (while both wait a stage lasts one
  control cycle, so this costs tenths of a second). Then it takes the next place on the shortest
  path (way lengths, its blocked ways left out) between its place and the mate's last heard
  place, planned from the lower place index to the higher, so that two robots with the same
  knowledge walk the same path towards each other and meet on it. At the mate's place it waits.

Measured (docs/rendezvous.md, with the variants tried and dropped): on paper 003's map with
random blockings and half the messages lost it meets in every one of 100 held-out episodes, in
21.6 s on average against 22.8 s for paper 003's ``bidir-astar`` with its protocol records; with
the channel cut no robot moves.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import networkx as nx
import numpy as np

from baselines.policy import Policy
from teamgym.envs.base import TeamEnv

#: Values per message entry (the ``--message-levels`` of the learned agent it teaches).
DEFAULT_LEVELS = 9
#: Stages a robot that has heard its mate still waits while the mate has not heard it.
DEFAULT_ACK_STAGES = 1
#: Message values: a place's grid cell (2) and the flag (1).
MESSAGE_SIZE = 3


def grid_codes(xy: np.ndarray, levels: int) -> np.ndarray:
    """``(places, 2)``: each place's own cell of a ``levels`` × ``levels`` grid in [-1, 1]², as values on the grid.

    Positions are scaled to [-1, 1] over the places' extent; place ``i`` (in index order) takes the
    free cell nearest its scaled position (ties: the lower cell index, row-major)."""
    xy = np.asarray(xy, dtype=np.float64)
    if len(xy) > levels * levels:
        raise ValueError(f"{len(xy)} places do not fit a {levels} x {levels} message grid")
    low, high = xy.min(axis=0), xy.max(axis=0)
    span = np.where(high > low, high - low, 1.0)
    unit = 2.0 * (xy - low) / span - 1.0
    axis = np.linspace(-1.0, 1.0, levels)
    cells = np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1).reshape(-1, 2)
    free = np.ones(len(cells), dtype=bool)
    codes = np.zeros_like(unit)
    for i, point in enumerate(unit):
        cell = int(np.argmin(np.where(free, np.sum((cells - point) ** 2, axis=1), np.inf)))
        free[cell] = False
        codes[i] = cells[cell]
    return codes


@dataclass
class _Memory:
    """What one robot remembers: its mate's last message, the stages it waited for it, the blocked ways it found."""

    mate_place: int | None = None
    mate_heard_us: bool = False
    waited: int = 0
    blocked: set[frozenset[int]] = field(default_factory=set)


class PlaceBeacon(Policy):
    """Send the next place, walk towards the mate's last heard one; see the module docstring."""

    name = "place-beacon"
    env_ids: ClassVar[tuple[str, ...]] = ("Rendezvous-v0",)
    observation_fields: ClassVar[tuple[str, ...]] = ("place", "target", "neighbours", "blocked", "inbox", "inbox_mask")
    #: What ``baselines.evaluate`` sets when the env lacks it.
    required_config: ClassVar[dict[str, Any]] = {"action_type": "next_place", "protocol_messages": False, "comm_dim": 3}

    def __init__(self, env: TeamEnv, levels: int = DEFAULT_LEVELS, ack_stages: int = DEFAULT_ACK_STAGES) -> None:
        super().__init__(env)
        c = env.config
        if c.action_type != "next_place" or c.protocol_messages or c.comm_dim != MESSAGE_SIZE or c.n_robots != 2:
            raise ValueError("place-beacon needs n_robots=2, action_type='next_place', protocol_messages=False and comm_dim=3")
        for name, value, least in (("levels", levels, 2), ("ack_stages", ack_stages, 0)):
            if not isinstance(value, int) or isinstance(value, bool) or value < least:
                raise ValueError(f"place-beacon {name} must be an integer >= {least}, got {value!r}")
        self.levels, self.ack_stages, self.wait = levels, ack_stages, int(env.max_degree)
        self.graph: nx.Graph = env.graph
        #: Per place, the two message values that name it.
        self.codes = grid_codes(env.places_xy, levels)

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.memory: dict[str, _Memory] = {}

    def message(self, place: int, heard: bool) -> np.ndarray:
        """The message naming ``place``, flag 1 if the sender has heard its mate (-1 if not)."""
        return np.array([*self.codes[place], 1.0 if heard else -1.0], dtype=np.float32)

    def place_of(self, values: np.ndarray) -> int:
        """The place a heard message names: the nearest cell (lowest index on ties)."""
        heard = np.asarray(values, dtype=np.float64)[:2]
        return int(np.argmin(np.sum((self.codes - heard) ** 2, axis=1)))

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        actions = {}
        for agent, observation in observations.items():
            fields = self.env.decode(observation)
            place, target = int(fields["place"][0]), int(fields["target"][0])
            neighbours = fields["neighbours"].astype(int).tolist()
            memory = self.memory.setdefault(agent, _Memory())
            for q, flag in zip(neighbours, fields["blocked"].tolist()):
                if q >= 0 and flag:
                    memory.blocked.add(frozenset((place, q)))
            inbox, present = fields["inbox"].reshape(-1, MESSAGE_SIZE), fields["inbox_mask"].reshape(-1)
            for row in np.flatnonzero(present):
                memory.mate_place, memory.mate_heard_us = self.place_of(inbox[row]), bool(inbox[row][2] > 0)
            move, going = self._move(memory, place, target, neighbours)
            actions[agent] = {"motion": move, "message": self.message(going, memory.mate_place is not None)}
        return actions

    def _move(self, memory: _Memory, place: int, target: int, neighbours: list[int]) -> tuple[int, int]:
        """The motion slot and the place the robot is going to."""
        if target >= 0:  # on a way: it finishes it (its slot or "wait" both continue)
            return self.wait, target
        if memory.mate_place is None:
            return self.wait, place
        if not memory.mate_heard_us and memory.waited < self.ack_stages:
            memory.waited += 1
            return self.wait, place
        path = self._path(min(place, memory.mate_place), max(place, memory.mate_place), memory.blocked)
        if len(path) < 2:
            return self.wait, place
        step = path[1] if path[0] == place else path[-2]
        if step not in neighbours:
            return self.wait, place
        return neighbours.index(step), step

    def _path(self, a: int, b: int, blocked: set[frozenset[int]]) -> list[int]:
        """The shortest path (way lengths) from ``a`` to ``b`` without the ``blocked`` ways; [] if there is none.

        networkx's bidirectional Dijkstra (``shortest_path``), not the one-sided one of
        :func:`~baselines.rendezvous.search.centralized_shortest_path`: they break ties between equal paths
        differently (2 of the 100 held-out episodes change), and the shipped clone learned this one."""

        def length(u: int, v: int, data: dict) -> float | None:
            return None if frozenset((u, v)) in blocked else data["length"]

        try:
            return [int(p) for p in nx.shortest_path(self.graph, a, b, weight=length)]
        except nx.NetworkXNoPath:
            return []
