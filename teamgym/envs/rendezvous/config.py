"""Configuration of ``Rendezvous-v0`` (paper 003) and the per-process graph-map cache."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar, Literal

from teamgym.envs.bounds import PROXIMITY_LIMITS, Limit, require_limits, require_ring_noise
from teamgym.envs.config import ConfigError, EnvConfig, require, require_together
from teamgym.maps.graph import GraphMap, load_graph_map
from teamgym.maps.model import MapError


@functools.lru_cache(maxsize=32)
def cached_graph_map(name: str) -> GraphMap:
    """A shipped graph map by name or a graph-map file by path, loaded once per process."""
    return load_graph_map(name)


@dataclass(frozen=True)
class RendezvousConfig(EnvConfig):
    """Configuration of ``Rendezvous-v0`` (SI units; place ids are the map's).

    Map coordinates and way lengths are multiplied by ``scale`` (m per map unit) in the world.
    ``neighbour_offsets=True`` (for learned policies) appends the world offset (m) of each
    neighbour slot's place from the robot to its observation.
    ``READING_LIMITS`` (the proximity ring): ``sensor_range`` and ``sensor_noise`` in [0, 10] m,
    and ``sensor_noise`` at most ``sensor_range`` (a larger std saturates every ray).
    """

    #: Own ranges of the keys that scale a sensor reading (see the class docstring).
    READING_LIMITS: ClassVar[dict[str, Limit]] = PROXIMITY_LIMITS

    body_speed_keys: ClassVar[tuple[str, ...]] = ("max_speed",)
    default_body_speed: ClassVar[float] = 0.0

    max_cycles: int = 6000
    map: str = "paper003_fig5"
    n_robots: int = 2
    start_places: tuple[str, ...] = ()
    scale: float = 0.5
    corridor_width: float = 0.14
    corridor_walls: bool = True
    blocked_ways: tuple[tuple[str, str], ...] = ()
    blockings: tuple[tuple[str, str, float], ...] = ()
    arrival_blockings: tuple[tuple[str, str, str, int], ...] = ()
    block_rate: float = 0.0
    speeds: tuple[float, ...] = ()
    max_speed: float = 0.2
    meet_distance: float = 0.1
    action_type: Literal["next_place", "velocity"] = "next_place"
    stage_end: Literal["any", "all"] = "any"
    protocol_messages: bool = False
    message_len: int = 128
    neighbour_offsets: bool = False
    sensor_range: float = 0.1
    sensor_noise: float = 0.0
    meet_bonus: float = 10.0
    progress_reward: float = 1.0
    collision_penalty: float = 1.0
    time_penalty: float = 0.01

    def check(self) -> None:
        super().check()
        require(self, "n_robots", 2 <= self.n_robots <= 8, "must be in [2, 8]")
        require(self, "scale", 0.05 <= self.scale <= 100, "must be in [0.05, 100] m per map unit")
        require(self, "corridor_width", 0.07 <= self.corridor_width <= 2.0, "must be in [0.07, 2] m (a robot is 0.055 m wide)")
        require(self, "block_rate", self.block_rate >= 0, "must be >= 0 per second")
        require(self, "max_speed", 0 < self.max_speed <= 0.4, "must be in (0, 0.4] m/s")
        require(self, "speeds", all(0 < v <= 0.4 for v in self.speeds), "must hold speeds in (0, 0.4] m/s")
        require(self, "meet_distance", 0.06 <= self.meet_distance <= 10, "must be in [0.06, 10] m (robots touch at 0.055 m)")
        require(self, "message_len", 8 <= self.message_len <= 100_000, "must be in [8, 100000]")
        require(self, "sensor_range", self.sensor_range > 0, "must be > 0")
        require(self, "sensor_noise", self.sensor_noise >= 0, "must be >= 0")
        require_limits(self, self.READING_LIMITS)
        require(
            self, "blockings", all(len(w) == 3 and w[2] >= 0 for w in self.blockings), "must hold (a, b, time) with times >= 0 s"
        )
        require(
            self,
            "arrival_blockings",
            all(len(w) == 4 and w[3] >= 1 for w in self.arrival_blockings),
            "must hold (a, b, place, visit) with visit >= 1",
        )
        try:
            cached_graph_map(self.map)
        except MapError as error:
            raise ConfigError(f"RendezvousConfig: map={self.map!r} is invalid: {error}") from None

    def check_relations(self) -> None:
        super().check_relations()
        require_ring_noise(self, self.sensor_noise)
        graph_map = cached_graph_map(self.map)
        ids = set(graph_map.place_ids)
        require_together(
            self, ("n_robots", "map"), self.n_robots <= len(ids), f"n_robots exceeds the {len(ids)} places of the map"
        )
        unknown = [p for p in self.start_places if p not in ids]
        require_together(self, ("start_places", "map"), not unknown, f"start_places names unknown place(s) {unknown}")
        require_together(
            self,
            ("start_places", "n_robots"),
            len(self.start_places) in (0, self.n_robots) and len(set(self.start_places)) == len(self.start_places),
            f"start_places must be empty (random) or give {self.n_robots} distinct places",
        )
        ends = {x.ends for x in graph_map.ways}
        for key, ways in (("blocked_ways", self.blocked_ways), ("blockings", [w[:2] for w in self.blockings])):
            missing = [w for w in ways if len(w) != 2 or frozenset(w) not in ends]
            require_together(self, (key, "map"), not missing, f"{key} names way(s) {missing} that the map does not have")
        require_together(
            self,
            ("arrival_blockings", "map"),
            all(frozenset(w[:2]) in ends and w[2] in ids for w in self.arrival_blockings),
            "arrival_blockings must name a way a–b and a place of the map",
        )
        require_together(
            self,
            ("speeds", "n_robots", "max_speed"),
            len(self.speeds) in (0, self.n_robots) and all(v <= self.max_speed for v in self.speeds),
            f"speeds must be empty (0.1 m/s each) or give {self.n_robots} speeds in (0, max_speed]",
        )

    @property
    def graph_map(self) -> GraphMap:
        return cached_graph_map(self.map)
