"""Beacon: a small, complete example env (the walkthrough is ``docs/adding_an_env.md``).

``n_robots`` Khepera robots start at random in a walled square arena (``arena_size`` m a
side). A beacon sits at a random point at least ``goal_radius / 2`` from the walls; a robot
sees it only within ``sense_range``. The team succeeds when every robot is within
``goal_radius`` of the beacon (:meth:`Beacon.episode_success`); all agents then terminate.

Communication: in the sensing phase every live robot that sees the beacon broadcasts an
env-generated message on the core channel: kind ``"beacon"``, payload the beacon's ``(x, y)``
(m), size :data:`REPORT_BYTES` = 8 (two float32). The radio is the base config's
``comm_range``, ``comm_throughput``, ``comm_latency`` and ``comm_byte_budget``; with latency 0
a report is in the same step's observations of the robots in range (none at ``reset``).

Observation fields (``env.decode(obs)``; ``obs_format="dict"`` gives them as a Dict), with
K = max(1, n_robots − 1) report slots (each other robot sends at most one report a step):

=================  ======  =====  ====================================================
field              shape   dtype  meaning
=================  ======  =====  ====================================================
``position``       (2,)    f32    own x, y (m), in [0, arena_size]
``heading``        (1,)    f32    own θ (rad, CCW from +x), in [−π, π]
``proximity``      (8,)    f32    Khepera ring distances (m), ``sensor_range`` if free
``beacon_seen``    (1,)    int8   1 if the beacon is within ``sense_range``, else 0
``beacon_offset``  (2,)    f32    beacon minus own position (m); zeros if not seen
``reports``        (K, 2)  f32    beacon positions received this step, zero-padded
``report_mask``    (K,)    int8   1 for a received report, 0 for padding
=================  ======  =====  ====================================================

Actions: continuous (v, ω) (:class:`~teamgym.envs.actions.VelocityAction`).
Reward per step: ``progress_reward`` × (decrease of the distance to the beacon, m)
− ``time_penalty`` − ``collision_penalty`` × (contacts begun in the step).
Metrics in ``infos[agent]``: ``distance_to_beacon`` (m), ``beacon_seen`` (0/1),
``collisions`` (this episode) and the channel counters (``bytes_sent``, ...) from ``reset`` on.
Reset options fix a scene: ``{"beacon": (x, y), "starts": [(x, y, θ), ...]}`` (other keys are refused).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv

from teamgym.envs.actions import ActionType, VelocityAction
from teamgym.envs.base import TeamEnv
from teamgym.envs.config import ConfigError, EnvConfig, require, require_together
from teamgym.envs.infos import InfoKey, metrics
from teamgym.envs.reset_input import scene_points
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.sim.render import Overlay
from teamgym.sim.robot import DiffDriveRobot, RobotSpec, wrap_angle
from teamgym.sim.sensors import KHEPERA_RING, ProximityRing
from teamgym.sim.world import World

__all__ = ["REPORT_BYTES", "Beacon", "BeaconConfig", "env", "parallel_env"]

#: Bytes a beacon report counts in the channel's byte budget and counters (x, y as float32).
REPORT_BYTES = 8
#: Every robot is a Khepera (55 mm diameter, 0.4 m/s).
SPEC = RobotSpec()


@dataclass(frozen=True)
class BeaconConfig(EnvConfig):
    """Configuration of the Beacon example (SI units); see the module docstring."""

    n_robots: int = 3
    arena_size: float = 2.0
    sense_range: float = 0.5
    goal_radius: float = 0.25
    action_type: Literal["velocity"] = "velocity"  # one choice; the API and regression tests read this key
    sensor_range: float = 0.1
    sensor_noise: float = 0.0
    progress_reward: float = 1.0
    time_penalty: float = 0.01
    collision_penalty: float = 0.1

    def check(self) -> None:
        super().check()
        require(self, "n_robots", 1 <= self.n_robots <= 16, "must be in [1, 16]")
        require(self, "arena_size", 0.5 <= self.arena_size <= 20, "must be in [0.5, 20] m")
        require(self, "sense_range", 0 < self.sense_range <= 20, "must be in (0, 20] m")
        require(self, "goal_radius", 0.05 <= self.goal_radius <= 20, "must be in [0.05, 20] m")
        require(self, "sensor_range", 0 < self.sensor_range <= 1, "must be in (0, 1] m")
        require(self, "sensor_noise", self.sensor_noise >= 0, "must be >= 0 m")
        for key in ("progress_reward", "time_penalty", "collision_penalty"):
            require(self, key, getattr(self, key) >= 0, "must be >= 0")

    def check_relations(self) -> None:
        super().check_relations()
        r = SPEC.radius
        require_together(
            self, ("sense_range", "arena_size"), self.sense_range <= self.arena_size, "sense_range must not exceed arena_size"
        )
        require_together(
            self, ("goal_radius", "sense_range"), self.goal_radius <= self.sense_range, "goal_radius must not exceed sense_range"
        )
        fits = self.n_robots * (2 * r) ** 2 <= 0.25 * math.pi * self.goal_radius**2
        require_together(
            self, ("goal_radius", "n_robots"), fits, f"the goal is too small for {self.n_robots} robots to gather in"
        )
        side = self.arena_size - 2 * (r + 0.05)
        require_together(
            self,
            ("n_robots", "arena_size"),
            self.n_robots * (4 * r) ** 2 <= 0.5 * side**2,
            "they leave too little room in this arena",
        )


class Beacon(TeamEnv):
    """Find a beacon that only nearby robots see and gather around it; see the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "beacon_v0"}
    config_class = BeaconConfig
    reset_option_keys = ("beacon", "starts")
    uses_channel = True  # beacon reports: channel counters in infos from reset on
    config: BeaconConfig

    # -- construction: once per env, from the config alone --------------------------------
    def _agent_names(self) -> list[str]:
        return [f"robot_{i}" for i in range(self.config.n_robots)]

    def _setup(self) -> None:
        c = self.config
        self.ring = ProximityRing(KHEPERA_RING, c.sensor_range, c.sensor_noise)
        self.capacity = max(1, c.n_robots - 1)
        # Global state: x, y, θ of every robot, then the beacon's x, y.
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(3 * c.n_robots + 2,), dtype=np.float32)

    def _make_action_type(self) -> ActionType:
        return VelocityAction(SPEC)

    def _make_layout(self) -> ObservationLayout:
        c, s = self.config, self.config.arena_size
        return ObservationLayout(
            [
                Field("position", (2,), 0.0, s),
                Field("heading", (1,), -math.pi, math.pi),
                Field("proximity", (self.ring.width,), 0.0, c.sensor_range),
                Field("beacon_seen", (1,), 0, 1, np.int8),
                Field("beacon_offset", (2,), -s, s),
                Field("reports", (self.capacity, 2), 0.0, s),
                Field("report_mask", (self.capacity,), 0, 1, np.int8),
            ]
        )

    # -- a new episode ----------------------------------------------------------------------
    def _build(self, rng: np.random.Generator) -> None:
        c = self.config
        self.world = World((c.arena_size, c.arena_size), **c.world_options())
        self.world.add_boundary()
        self.beacon, starts = self._scene(rng)
        self.robots = {
            a: self.world.add(DiffDriveRobot(a, (x, y), theta, SPEC)) for a, (x, y, theta) in zip(self.possible_agents, starts)
        }
        self._robot_list = list(self.robots.values())
        n = c.n_robots
        self._collisions = np.zeros(n, dtype=np.int64)
        self._proximity = np.zeros((n, self.ring.width), dtype=np.float32)
        self.world.read_states()
        self._read_world()
        self._check_goals()
        self._read_sensors()

    def _scene(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """The beacon ``(x, y)`` and the starts ``(n, 3)``: drawn, then replaced by reset options."""
        c, r = self.config, SPEC.radius
        s, margin = c.arena_size, r + 0.05
        beacon = rng.uniform(0.5 * c.goal_radius, s - 0.5 * c.goal_radius, size=2)
        starts = np.zeros((c.n_robots, 3))
        for i in range(c.n_robots):
            for _ in range(10_000):
                p = rng.uniform(margin, s - margin, size=2)
                if np.all(np.linalg.norm(starts[:i, :2] - p, axis=1) >= 4 * r):
                    break
            else:
                raise ConfigError(f"BeaconConfig: could not place {c.n_robots} robots in a {s} m arena")
            starts[i] = (p[0], p[1], rng.uniform(-math.pi, math.pi))
        return self.reset_options.get("beacon", beacon), self.reset_options.get("starts", starts)

    def _check_reset_options(self, options: dict) -> dict:
        """``beacon`` ``(2,)`` and ``starts`` ``(n, 3)``, points in the arena (starts a radius inside), or ValueError."""
        c, size = self.config, (self.config.arena_size, self.config.arena_size)
        shapes = {"beacon": ((2,), 0.0), "starts": ((c.n_robots, 3), SPEC.radius)}
        return {key: scene_points(key, value, shapes[key][0], size, shapes[key][1]) for key, value in options.items()}

    # -- step phases, in the order TeamEnv.step runs them -----------------------------------
    def _read_world(self) -> None:
        states = self.world.robot_states  # rows in the order the robots were added
        self._pos = states[:, :2].copy()
        self._theta = wrap_angle(states[:, 2])
        self._distance = np.linalg.norm(self._pos - self.beacon, axis=1)

    def _update_state(self) -> None:
        """State phase: poses, progress towards the beacon, contacts begun in this step."""
        before = self._distance
        self._read_world()
        self._progress = before - self._distance
        self._hits = self.world.contacts_per(self.possible_agents)
        self._collisions += self._hits

    def _check_goals(self) -> None:
        self._success = bool(np.all(self._distance <= self.config.goal_radius))

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        c, live = self.config, [self._row[a] for a in self.live_agents]
        total[live] += c.progress_reward * self._progress[live] - c.time_penalty - c.collision_penalty * self._hits[live]

    def _read_sensors(self) -> None:
        self._seen = self._distance <= self.config.sense_range
        self.ring.read_rows(self.world, self._robot_list, self.world.robot_states, self.np_random, self._proximity)

    def _sense(self) -> None:
        """Sensing phase: read the sensors; robots that see the beacon broadcast it (delivered this step)."""
        self._read_sensors()
        payload = np.asarray(self.beacon, dtype=np.float32)
        for agent in self.live_agents:
            if self._seen[self._row[agent]]:
                self.channel.send(agent, payload, size=REPORT_BYTES, kind="beacon")

    def _terminations(self) -> dict[str, bool]:
        return dict.fromkeys(self.live_agents, self._success)

    # -- outputs ------------------------------------------------------------------------------
    def _observe(self, out: np.ndarray) -> None:
        view, s = self.layout.view, self.config.arena_size
        for obs, agent in zip(out, self.live_agents):
            i = self._row[agent]
            view(obs, "position")[:] = np.clip(self._pos[i], 0.0, s)
            view(obs, "heading")[0] = self._theta[i]
            view(obs, "proximity")[:] = self._proximity[i]
            if self._seen[i]:
                view(obs, "beacon_seen")[0] = 1
                view(obs, "beacon_offset")[:] = self.beacon - self._pos[i]
            packed = self.channel.inbox_array(agent, width=2, capacity=self.capacity, kind="beacon")
            view(obs, "reports")[:] = packed.payload
            view(obs, "report_mask")[:] = packed.mask

    def _info_keys(self) -> dict[str, InfoKey]:
        """Every key of ``_metrics``, known from reset on (a key a task adds later holds NaN until known: ``unknown``)."""
        return metrics("distance_to_beacon", "beacon_seen", "collisions")

    def _metrics(self, agent: str) -> dict[str, Any]:
        i = self._row[agent]
        return {
            "distance_to_beacon": float(self._distance[i]),
            "beacon_seen": int(self._seen[i]),
            "collisions": int(self._collisions[i]),
        }

    def episode_success(self) -> bool:
        """Every robot is within ``goal_radius`` of the beacon."""
        return self.world is not None and self._success

    def state(self) -> np.ndarray:
        """x, y, θ of every robot, then the beacon's x, y (see ``state_space``)."""
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        return np.concatenate([np.column_stack([self._pos, self._theta]).ravel(), self.beacon]).astype(np.float32)

    def _overlay(self) -> Overlay:
        angles = np.linspace(0.0, 2 * math.pi, 33)
        circle = self.beacon + self.config.goal_radius * np.column_stack([np.cos(angles), np.sin(angles)])
        orange = (230, 160, 0)
        return Overlay(points=[(tuple(self.beacon), orange)], paths=[([tuple(p) for p in circle], orange)])


def parallel_env(render_mode: str | None = None, **config: Any) -> Beacon:
    """The PettingZoo parallel env; ``config`` holds :class:`BeaconConfig` keys."""
    return Beacon(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any) -> AECEnv:
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
