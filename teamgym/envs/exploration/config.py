"""Configuration of ``Exploration-v0`` (paper 000) and the per-process map cache."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar, Literal

from teamgym.envs.bounds import PROXIMITY_LIMITS, Limit, require_limits, require_ring_noise
from teamgym.envs.config import ConfigError, EnvConfig, require, require_together
from teamgym.maps.model import MapError, OfficeMap, load_map
from teamgym.sim.robot import RobotSpec


@functools.lru_cache(maxsize=32)
def cached_map(name: str) -> OfficeMap:
    """A shipped map by name or a map file by path, loaded once per process."""
    return load_map(name)


@dataclass(frozen=True)
class ExplorationConfig(EnvConfig):
    """Configuration of ``Exploration-v0`` (SI units; ids are the map's sector and door ids).

    ``READING_LIMITS`` (the proximity ring): ``sensor_range`` and ``sensor_noise`` in [0, 10] m,
    and ``sensor_noise`` at most ``sensor_range`` (a larger std saturates every ray).
    """

    #: Own ranges of the keys that scale a sensor reading (see the class docstring).
    READING_LIMITS: ClassVar[dict[str, Limit]] = PROXIMITY_LIMITS

    max_cycles: int = 3000
    map: str = "office12"
    n_robots: int = 3
    action_type: Literal["velocity", "operator"] = "velocity"
    goal_sectors: tuple[str, ...] = ()
    start_sectors: tuple[str, ...] = ()
    start_positions: Literal["random", "centre"] = "random"
    door_states: Literal["sample", "open"] = "sample"
    open_doors: tuple[str, ...] = ()
    closed_doors: tuple[str, ...] = ()
    door_resample_period: float = 0.0
    furniture: bool = True
    stage_end: Literal["any", "all"] = "any"
    wait_steps: int = 10
    max_speed: float = 0.12
    task_timeout: float = 60.0
    stall_time: float = 5.0
    fail_on_collision: bool = False
    clutter_prior_weight: float = 5.0
    sensor_range: float = 0.1
    sensor_noise: float = 0.0
    explore_reward: float = 1.0
    collision_penalty: float = 0.1
    time_penalty: float = 0.001

    def check(self) -> None:
        super().check()
        require(self, "n_robots", 1 <= self.n_robots <= 16, "must be in [1, 16]")
        require(self, "door_resample_period", self.door_resample_period >= 0, "must be >= 0 (0: never)")
        require(self, "wait_steps", self.wait_steps >= 1, "must be >= 1")
        require(self, "max_speed", 0 < self.max_speed <= RobotSpec.max_wheel_speed, "must be in (0, 0.4] m/s")
        require(self, "task_timeout", self.task_timeout > 0, "must be > 0")
        require(self, "stall_time", self.stall_time > 0, "must be > 0")
        require(self, "clutter_prior_weight", self.clutter_prior_weight > 0, "must be > 0")
        require(self, "sensor_range", self.sensor_range > 0, "must be > 0")
        require(self, "sensor_noise", self.sensor_noise >= 0, "must be >= 0")
        require_limits(self, self.READING_LIMITS)
        both = sorted(set(self.open_doors) & set(self.closed_doors))
        require(self, "closed_doors", not both, f"names door(s) {both} that open_doors also names")
        try:
            cached_map(self.map)
        except MapError as error:
            raise ConfigError(f"ExplorationConfig: map={self.map!r} is invalid: {error}") from None

    def check_relations(self) -> None:
        super().check_relations()
        require_ring_noise(self, self.sensor_noise)
        office = cached_map(self.map)
        sectors, doors = set(office.sector_ids), set(office.door_ids)
        for key in ("goal_sectors", "start_sectors"):
            unknown = [s for s in getattr(self, key) if s not in sectors]
            require_together(
                self, (key, "map"), not unknown, f"{key} names unknown sector(s) {unknown}; the map has {office.sector_ids}"
            )
        require_together(
            self,
            ("start_sectors", "n_robots"),
            len(self.start_sectors) in (0, self.n_robots),
            f"start_sectors must be empty (random) or give one sector per robot ({self.n_robots})",
        )
        for key in ("open_doors", "closed_doors"):
            unknown = [d for d in getattr(self, key) if d not in doors]
            require_together(
                self, (key, "map"), not unknown, f"{key} names unknown door(s) {unknown}; the map has {office.door_ids}"
            )
