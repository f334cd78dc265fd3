"""The centralised reference for Rendezvous-v0: one planner that sees every robot (``centralized``).

It reads both robots' observations each step (places, and the blocked ways each has
detected), keeps the union of the detections, and re-plans networkx's shortest path between
the robots' places whenever a new blocking is detected or a robot leaves the path. A robot
standing at a place takes the next place toward its partner (robot_0 walks the path forward,
robot_1 backward) and waits where its partner is coming. Its plans are announced as PATH
records so that the env scores them like the distributed ones (always optimal by
construction); it sends no other message.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from baselines.policy import Policy
from baselines.rendezvous.protocol import check_message_len
from baselines.rendezvous.search import centralized_shortest_path
from teamgym.envs.base import TeamEnv
from teamgym.envs.rendezvous.messages import Kind, encode


class CentralizedRendezvous(Policy):
    """Shortest path between the robots, re-planned on every blocking; see the module docstring."""

    name = "centralized"
    env_ids: ClassVar[tuple[str, ...]] = ("Rendezvous-v0",)
    observation_fields: ClassVar[tuple[str, ...]] = ("place", "target", "neighbours", "blocked")
    required_config: ClassVar[dict[str, Any]] = {"action_type": "next_place", "protocol_messages": True}

    def __init__(self, env: TeamEnv) -> None:
        super().__init__(env)
        if env.config.n_robots != 2 or env.config.action_type != "next_place" or not env.config.protocol_messages:
            raise ValueError("the centralized reference needs n_robots=2, action_type='next_place' and protocol_messages=True")
        check_message_len(env)
        self.graph = env.graph
        self.wait = env.max_degree
        self.length = env.config.message_len

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.blocked: set[frozenset[int]] = set()
        self.path: list[int] = []

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        agents = self.env.possible_agents
        fields = {a: self.env.decode(o) for a, o in observations.items()}
        places = {a: int(f["place"][0]) for a, f in fields.items()}
        targets = {a: int(f["target"][0]) for a, f in fields.items()}
        news = False
        for a, f in fields.items():
            for q, flag in zip(f["neighbours"].astype(int).tolist(), f["blocked"].tolist()):
                way = frozenset((places[a], q))
                if q >= 0 and flag and way not in self.blocked:
                    self.blocked.add(way)
                    news = True
        ends = [targets[a] if targets[a] >= 0 else places[a] for a in agents]
        records = []
        if news or not self.path or ends[0] not in self.path or ends[1] not in self.path:
            result = centralized_shortest_path(self.graph, ends[0], ends[1], self.blocked)
            if result.found:
                self.path = list(result.path)
                records.append((Kind.PATH, (0, *self.path)))
        actions = {}
        for k, a in enumerate(agents):
            move = self.wait
            if a in fields and targets[a] < 0 and self.path:
                move = self._next_move(fields[a], places[a], ends[1 - k], self.path if k == 0 else self.path[::-1])
            message = records if k == 0 else []
            if a in observations:
                actions[a] = {"move": move, "message": encode(message, self.length)}
        return actions

    def _next_move(self, fields: dict[str, np.ndarray], place: int, partner_end: int, path: list[int]) -> int:
        if place not in path or place == partner_end:
            return self.wait
        k = path.index(place)
        if k + 1 >= len(path):
            return self.wait
        neighbours = fields["neighbours"].astype(int).tolist()
        return neighbours.index(path[k + 1]) if path[k + 1] in neighbours else self.wait
