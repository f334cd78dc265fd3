"""Navigation-v0: collision-free navigation of a robot team among moving obstacles (paper 001).

``n_robots`` differential-drive robots in a square arena (2 m × 2 m by default) each drive
to their own goal point while ``n_obstacles`` convex polygons move on straight lines at
``obstacle_speed`` (20 cm/s in the paper) and bounce off the arena walls.

Workspace (``walls``, ``obstacle_motion``): by default the arena is walled and obstacles
reflect at its edges. Paper 001's workspace W has no walls ("N mobile robots sharing the
same workspace W with M moving obstacles inside"): ``walls=False`` removes them, so robots
may drive out of the square and cannot be pinned against a wall, while obstacles still
reflect at the square's edges and stay inside it (``obstacle_motion="bounce"``) or, with
``obstacle_motion="straight"``, keep one straight line for the whole episode (the
constant-velocity model of eq. 23) and leave the square when their line does; a straight
obstacle is aimed at a random point of the middle half of the square, so that it crosses
the robots' workspace rather than leaving it at once, and passes over other obstacles
(robots still stop it). Starts, goals and obstacles are always sampled inside the square.

Observations (flat float32, fields in order; decode with ``env.decode(obs)``):

=================  ============  ===================================================
field              shape         meaning
=================  ============  ===================================================
``pose``           (3,)          own x, y (m) and heading θ (rad, CCW from +x)
``velocity``       (2,)          own actual v (m/s, along heading) and ω (rad/s)
``last_command``   (2,)          the (v, ω) commanded in the previous step
``radius``         (1,)          own body radius (m)
``goal_offset``    (2,)          goal position minus own position (world axes, m)
``mates``          (N−1, 5)      per team mate: Δx, Δy (world axes), θ, v, ω
``obstacles``      (M, 5)        per obstacle: Δx, Δy of its centre, vx, vy, bounding radius
``proximity``      (8,)          Khepera ring distances (m), ``sensor_range`` if free
=================  ============  ===================================================

With ``local_features`` the fields ``goal_local`` (2,), ``mates_local`` (N−1, 4: Δx, Δy,
vx, vy) and ``obstacles_local`` (M, 4) follow, in the robot's own frame (x ahead, y left);
with ``mate_goals`` then ``mate_goals`` (N−1, 2): each mate's goal relative to the robot
(own frame with ``local_features``, else world axes). Both are off by default (for RL).

This is the paper's "partially centralised sensory system": every robot knows the poses of
its team mates and the positions of the obstacles (section 2).

Actions (``action_type``): ``"velocity"`` continuous (v, ω); ``"wheels"`` continuous wheel
speeds; ``"heading"`` the discrete set of eq. (11), K = ``heading_levels`` angular
velocities with v from eqs. (12)–(13).

Actuation delay (section 6.1): with ``actuation_delay`` = T0 > 0 every robot keeps its
previous command for T0_true = ½ T0 (1 + δt) of each step. The paper calls δt ∈ [0, 1]
normally distributed; we draw δt ~ N(0.5, 0.25²) clipped to [0, 1].

Reward per step: ``progress_reward`` × (decrease of the distance to the goal, m)
− ``time_penalty`` − ``collision_penalty`` × (new contacts) + ``arrival_bonus`` on arrival.
A robot that arrives (within ``goal_tolerance``) terminates, stops and stays in the world.

Metrics in ``infos[agent]``: ``arrived``, ``time_to_goal`` (s; present once arrived),
``distance_to_goal``, ``path_length``, ``collisions``, ``min_clearance`` (smallest gap
between the robot's rim and another robot or obstacle, m), ``min_center_distance``
(smallest centre-to-centre distance to a robot or obstacle centre, as eqs. 20 and 22
measure it) and ``smoothness`` J_i = (1/H) Σ ‖u(t_n) − u(t_{n−1})‖² with u = (ω, v) in rad/s
and m/s (section 6.2).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.control.heading import HeadingHeuristic, nearest_gap
from teamgym.envs.actions import ActionType, VelocityAction, WheelSpeedAction
from teamgym.envs.base import TeamEnv
from teamgym.envs.config import ConfigError
from teamgym.envs.navigation.actions import HeadingAction
from teamgym.envs.navigation.config import NavigationConfig
from teamgym.envs.navigation.scene import NavigationScene, PlacementError, scatter
from teamgym.envs.spaces import ObservationLayout
from teamgym.sim.categories import SOLID, Category
from teamgym.sim.chipmunk import shape_distance
from teamgym.sim.objects import MovingPolygon, regular_polygon
from teamgym.sim.render import Overlay, robot_colour
from teamgym.sim.robot import DiffDriveRobot, RobotSpec
from teamgym.sim.sensors import KHEPERA_RING, ProximityRing
from teamgym.sim.world import World

__all__ = ["Navigation", "NavigationConfig", "env", "parallel_env"]


class Navigation(TeamEnv):
    """Collision-free navigation among moving obstacles (paper 001). See the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "navigation_v0"}
    config_class = NavigationConfig
    config: NavigationConfig

    def _setup(self) -> None:
        c = self.config
        self.spec_robot = RobotSpec(
            radius=c.robot_radius,
            max_wheel_speed=c.max_wheel_speed,
            max_motor_force=c.max_motor_force,
            wheel_base=min(RobotSpec.wheel_base, 2 * c.robot_radius),
        )
        self.heuristic = HeadingHeuristic(c.v_opt, c.alpha, c.beta, c.target_threshold, c.object_threshold)
        self.ring = ProximityRing(KHEPERA_RING, c.sensor_range, c.sensor_noise)
        n, m = c.n_robots, c.n_obstacles
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(7 * n + 4 * m,), dtype=np.float32)
        self._others = np.array([[j for j in range(n) if j != i] for i in range(n)], dtype=int).reshape(n, n - 1)

    def _check_feasible(self) -> None:
        """Refuse at ``make()`` a config whose scenes cannot be sampled (tried on 32 seeds)."""
        for seed in range(32):
            try:
                self._sample_scene(np.random.default_rng(seed))
            except PlacementError as error:
                raise ConfigError(f"NavigationConfig: {error} (seed {seed})") from None

    # -- construction ----------------------------------------------------------------
    def _agent_names(self) -> list[str]:
        return [f"robot_{i}" for i in range(self.config.n_robots)]

    def _make_action_type(self) -> ActionType:
        c = self.config
        if c.action_type == "velocity":
            return VelocityAction(self.spec_robot)
        if c.action_type == "wheels":
            return WheelSpeedAction(self.spec_robot)
        return HeadingAction(c.heading_levels, c.heading_max_rate, self.heuristic)

    def _make_layout(self) -> ObservationLayout:
        n, m = self.config.n_robots, self.config.n_obstacles
        return ObservationLayout(
            [
                ("pose", (3,)),
                ("velocity", (2,)),
                ("last_command", (2,)),
                ("radius", (1,)),
                ("goal_offset", (2,)),
                ("mates", (n - 1, 5)),
                ("obstacles", (m, 5)),
                ("proximity", (len(KHEPERA_RING),)),
                *self._local_fields(),
            ]
        )

    def _local_fields(self) -> list[tuple[str, tuple[int, ...]]]:
        n, m = self.config.n_robots, self.config.n_obstacles
        fields = [("goal_local", (2,)), ("mates_local", (n - 1, 4)), ("obstacles_local", (m, 4))]
        return (fields if self.config.local_features else []) + ([("mate_goals", (n - 1, 2))] if self.config.mate_goals else [])

    def _build(self, rng: np.random.Generator) -> None:
        c = self.config
        self.world = World((c.arena_size, c.arena_size), **c.world_options())
        if c.walls:
            self.world.add_boundary()
        try:
            scene = self._sample_scene(rng)
        except PlacementError as error:
            raise ConfigError(f"NavigationConfig: {error}") from None
        starts, headings, goals = scene.starts, scene.headings, scene.goals
        self.robots = {}
        for agent, start, heading in zip(self.possible_agents, starts, headings):
            self.robots[agent] = self.world.add(DiffDriveRobot(agent, tuple(start), float(heading), self.spec_robot))
        self.robot_list = list(self.robots.values())
        self.goals = goals
        bounce = c.obstacle_motion == "bounce"
        # Straight obstacles keep their line (eq. 23's model) even where two of them cross.
        mask = SOLID if bounce else SOLID & ~Category.OBSTACLE.bit
        self.obstacles = [
            self.world.add(MovingPolygon(f"obstacle_{k}", vertices, centre, velocity, bounce=bounce, collides_with=mask))
            for k, (vertices, centre, velocity) in enumerate(scene.obstacles)
        ]
        n = c.n_robots
        self._obstacle_radii = np.array([o.bounding_radius for o in self.obstacles], dtype=float)
        # Centre distance at which a robot touches each object (robots first, then obstacles'
        # bounding circles): gap = centre distance − contact radius.
        self._contact_radius = np.concatenate([np.full(n, 2 * c.robot_radius), c.robot_radius + self._obstacle_radii])
        self._robot_rows = np.arange(n)
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._arrived = np.zeros(n, dtype=bool)
        self._arrival_time = np.full(n, np.nan)
        self._collisions = np.zeros(n, dtype=int)
        self._new_collisions = np.zeros(n, dtype=int)
        self._smooth_sum = np.zeros(n)
        self._smooth_steps = np.zeros(n, dtype=int)
        self._last_command = np.zeros((n, 2))
        self._prev_command = np.zeros((n, 2))
        self.world.read_states()
        self._read_state()
        self._goal_distance = np.linalg.norm(self.goals - self._pos, axis=1)
        self._min_clearance = np.full(n, np.inf)
        self._min_center = np.full(n, np.inf)
        self._update_distances()
        self._proximity = np.full((n, self.ring.n_rays), c.sensor_range, dtype=np.float32)
        self._read_proximity(np.arange(n))

    def _sample_scene(self, rng: np.random.Generator, attempts: int = 20) -> NavigationScene:
        """Random starts, headings, goals and obstacles.

        Placement is sequential rejection sampling; when it gets stuck the whole scene is drawn
        again from the same stream (up to ``attempts`` times) before PlacementError is raised.
        """
        for attempt in range(attempts):
            try:
                starts, headings, goals = self._sample_starts_and_goals(rng)
                return NavigationScene(starts, headings, goals, self._sample_obstacles(rng, starts))
            except PlacementError:
                if attempt == attempts - 1:
                    raise
        raise AssertionError("unreachable")

    def _sample_starts_and_goals(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        c = self.config
        n, size, r = c.n_robots, c.arena_size, c.robot_radius
        margin = r + c.spawn_margin
        if c.layout == "circle":
            radius = 0.5 * size - margin - 0.05
            if n > 1 and 2 * radius * math.sin(math.pi / n) < 4 * r:
                raise PlacementError(f"{n} robots of radius {r} m do not fit on a circle in a {size} m arena")
            phase = rng.uniform(0, 2 * np.pi)
            angles = phase + 2 * np.pi * np.arange(n) / n
            centre = np.full(2, size / 2)
            starts = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
            goals = centre - (starts - centre)
            offsets = goals - starts
            return starts, np.arctan2(offsets[:, 1], offsets[:, 0]), goals
        separation = 4 * r
        starts = scatter(rng, n, size, margin, separation)
        goals = np.zeros_like(starts)
        for i in range(n):
            for _ in range(10_000):
                g = rng.uniform(margin, size - margin, size=2)
                if np.linalg.norm(g - starts[i]) < c.min_goal_distance:
                    continue
                if i and np.min(np.linalg.norm(goals[:i] - g, axis=1)) < separation:
                    continue
                goals[i] = g
                break
            else:
                raise PlacementError(
                    f"could not place {n} goals {c.min_goal_distance} m from their starts in a {size} m arena; "
                    "lower n_robots or min_goal_distance"
                )
        return starts, rng.uniform(-np.pi, np.pi, size=n), goals

    def _sample_obstacles(self, rng: np.random.Generator, starts: np.ndarray) -> list[tuple[list, tuple, tuple]]:
        """Obstacles as (vertices, centre, velocity): 3–6 sides, clear of the robots' starts."""
        c = self.config
        radius = c.obstacle_radius
        clear = max(radius + c.robot_radius + 0.1, 2 * radius + 0.05)
        centres = scatter(rng, c.n_obstacles, c.arena_size, radius + 0.02, clear, avoid=starts)
        obstacles = []
        for centre in centres:
            sides = int(rng.integers(3, 7))
            vertices = regular_polygon(sides, radius, rotation=float(rng.uniform(0, 2 * np.pi)))
            if c.obstacle_motion == "straight":
                # Aim across the middle half of the square, where the robots travel, so the
                # obstacle crosses the workspace instead of leaving it at once.
                aim = rng.uniform(0.25 * c.arena_size, 0.75 * c.arena_size, size=2) - centre
                direction = math.atan2(aim[1], aim[0])
            else:
                direction = rng.uniform(0, 2 * np.pi)
            velocity = (c.obstacle_speed * math.cos(direction), c.obstacle_speed * math.sin(direction))
            obstacles.append((vertices, (float(centre[0]), float(centre[1])), velocity))
        return obstacles

    # -- per-step state --------------------------------------------------------------
    def _read_state(self) -> None:
        """Copy robot and obstacle states from the world's last batch read."""
        robots, movers = self.world.robot_states, self.world.mover_states
        if len(robots) != len(self.robot_list):
            robots, movers = self.world.read_states()
        self._pos = robots[:, 0:2]
        angle = robots[:, 2]
        self._theta = np.pi - np.mod(np.pi - angle, 2 * np.pi)
        vel = np.empty((len(robots), 2))
        np.multiply(robots[:, 3], np.cos(angle), out=vel[:, 0])
        vel[:, 0] += robots[:, 4] * np.sin(angle)
        vel[:, 1] = robots[:, 5]
        self._vel = vel
        self._obs_pos = movers[:, 0:2]
        self._obs_vel = movers[:, 3:5]

    def _update_distances(self) -> None:
        """Nearest-object distances of every robot (to other robots and obstacles).

        Sets the offsets from each robot to each object (robots, then obstacles) and the gaps by
        centre distance minus radii (bounding radius for obstacles), used by the speed rule of
        eq. (12), and updates the clearance and centre-distance minima.
        """
        pos = self._pos
        n = len(pos)
        points = np.concatenate([pos, self._obs_pos]) if self.obstacles else pos
        offsets = points[None, :, :] - pos[:, None, :]
        d = np.sqrt(np.einsum("ijk,ijk->ij", offsets, offsets))
        d[self._robot_rows, self._robot_rows] = np.inf
        gaps = d - self._contact_radius
        exact = gaps.min(axis=1)
        if self.obstacles:
            # Bounding circles under-estimate the gap; measure the polygon exactly when near.
            near = gaps[:, n:] < 0.1
            if near.any():
                exact_obstacles = gaps[:, n:].copy()
                r, points = self.config.robot_radius, pos.tolist()
                for i, k in zip(*np.nonzero(near)):
                    exact_obstacles[i, k] = shape_distance(self.obstacles[k].shape, points[i]) - r
                exact = np.minimum(gaps[:, :n].min(axis=1), exact_obstacles.min(axis=1))
        self._object_gaps = gaps
        self._object_offsets = offsets
        np.minimum(self._min_clearance, exact, out=self._min_clearance)
        np.minimum(self._min_center, d.min(axis=1), out=self._min_center)

    def speed_inputs(self, agent: str) -> tuple[float, float]:
        """Inputs of the speed rule, eqs. (12)–(13): distance to the goal and L_min (m)."""
        i = self._index[agent]
        return float(self._goal_distance[i]), self._nearest_for_speed(i)

    def _nearest_for_speed(self, i: int) -> float:
        """L_min,i of eq. (12), by :func:`teamgym.control.heading.nearest_gap` (``speed_rule``)."""
        c = self.config
        return nearest_gap(
            self._object_offsets[i],
            self._object_gaps[i],
            float(self._theta[i]),
            self._proximity[i],
            self.ring.angles,
            c.sensor_range,
            c.speed_rule,
        )

    def _before_physics(self) -> None:
        c = self.config
        live = self._live_rows()
        self._prev_command[live] = self._last_command[live]
        robots = self.robot_list
        self._last_command[live] = [robots[i].command for i in live.tolist()]
        if c.actuation_delay > 0:
            delta = np.clip(self.np_random.normal(0.5, 0.25, size=len(self.robot_list)), 0.0, 1.0)
            for robot, d in zip(self.robot_list, delta.tolist()):
                robot.actuation_delay = 0.5 * c.actuation_delay * (1.0 + d)

    def _update_state(self) -> None:
        """Poses, distances, contacts, progress towards the goals and smoothness (section 6.2)."""
        self._read_state()
        self._update_distances()
        live = self._live_rows()
        self._live = live
        hits = self.world.contacts_per(self.agents)
        self._collisions[live] += hits
        self._new_collisions[live] += hits
        offset = self.goals - self._pos
        distance = np.sqrt(np.einsum("ij,ij->i", offset, offset))
        self._progress = self._goal_distance - distance
        self._goal_distance = distance
        du = self._last_command[live] - self._prev_command[live]
        self._smooth_sum[live] += np.einsum("ij,ij->i", du, du)
        self._smooth_steps[live] += 1

    def _check_goals(self) -> None:
        live = self._live
        self._arriving = self._goal_distance[live] < self.config.goal_tolerance
        newly = live[self._arriving]
        self._arrived[newly] = True
        self._arrival_time[newly] = self.cycles * self.config.dt

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        c, live = self.config, self._live
        reward = c.progress_reward * self._progress[live] - c.time_penalty - c.collision_penalty * self._new_collisions[live]
        reward += c.arrival_bonus * self._arriving
        self._new_collisions[live] = 0
        total[live] += reward

    def _sense(self) -> None:
        """Proximity rings of the robots that go on (arrived robots stop sensing)."""
        self._read_proximity(self._live[~self._arriving])

    def _terminations(self) -> dict[str, bool]:
        """A robot that arrives terminates, stops and stays in the world."""
        return dict(zip(self.agents, self._arrived[self._live_rows()].tolist()))

    def _read_proximity(self, indices: np.ndarray) -> None:
        if len(indices) == 0:
            return
        robots = [self.robot_list[i] for i in indices.tolist()]
        block = np.empty((len(indices), self.ring.width), dtype=np.float32)
        self.ring.read_rows(self.world, robots, self.world.robot_states[indices], self.np_random, block)
        self._proximity[indices] = block

    def _observe(self, out: np.ndarray) -> None:
        rows = self._live_rows()
        if len(rows) == 0:
            return
        s = self.layout.slices
        pos, theta, vel = self._pos, self._theta, self._vel
        own = pos[rows]
        out[:, 0:2] = own
        out[:, 2] = theta[rows]
        out[:, s["velocity"]] = vel[rows]
        out[:, s["last_command"]] = self._last_command[rows]
        out[:, s["radius"]] = self.config.robot_radius
        out[:, s["goal_offset"]] = self.goals[rows] - own
        k = len(rows)
        if self.config.n_robots > 1:
            others = self._others[rows]
            mates = out[:, s["mates"]].reshape(k, -1, 5)  # a view: writes land in ``out``
            mates[:, :, 0:2] = pos[others] - own[:, None, :]
            mates[:, :, 2] = theta[others]
            mates[:, :, 3:5] = vel[others]
        if self.obstacles:
            block = out[:, s["obstacles"]].reshape(k, -1, 5)  # a view
            block[:, :, 0:2] = self._obs_pos[None, :, :] - own[:, None, :]
            block[:, :, 2:4] = self._obs_vel[None, :, :]
            block[:, :, 4] = self._obstacle_radii[None, :]
        out[:, s["proximity"]] = self._proximity[rows]
        if self.config.local_features:
            self._observe_local(out, rows)
        if self.config.mate_goals and self.config.n_robots > 1:
            self._observe_mate_goals(out, rows)

    def _observe_mate_goals(self, out: np.ndarray, rows: np.ndarray) -> None:
        """Team mates' goals relative to each robot (own frame with ``local_features``, else world axes)."""
        offset = self.goals[self._others[rows]] - self._pos[rows][:, None, :]
        if self.config.local_features:
            offset = np.stack(self._robot_frame(rows)(offset[:, :, 0], offset[:, :, 1]), axis=2)
        out[:, self.layout.slices["mate_goals"]] = offset.reshape(len(rows), -1)

    def _robot_frame(self, rows: np.ndarray) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """``rotate(dx, dy)``: world-axis vectors (one row per robot of ``rows``) in that robot's frame (x ahead, y left)."""
        theta = self._theta[rows]
        cos, sin = np.cos(theta)[:, None], np.sin(theta)[:, None]

        def rotate(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return cos * dx + sin * dy, -sin * dx + cos * dy

        return rotate

    def _observe_local(self, out: np.ndarray, rows: np.ndarray) -> None:
        """Goal offset, mates' and obstacles' offsets and velocities rotated into each robot's frame (x ahead, y left)."""
        s, k = self.layout.slices, len(rows)
        own = self._pos[rows]
        rotate = self._robot_frame(rows)
        gx, gy = rotate(self.goals[rows, 0:1] - own[:, 0:1], self.goals[rows, 1:2] - own[:, 1:2])
        out[:, s["goal_local"]] = np.concatenate([gx, gy], axis=1)
        if self.config.n_robots > 1:
            others = self._others[rows]
            block = np.empty((k, others.shape[1], 4))
            offset = self._pos[others] - own[:, None, :]
            block[:, :, 0], block[:, :, 1] = rotate(offset[:, :, 0], offset[:, :, 1])
            speed, heading = self._vel[others, 0], self._theta[others]
            block[:, :, 2], block[:, :, 3] = rotate(speed * np.cos(heading), speed * np.sin(heading))
            out[:, s["mates_local"]] = block.reshape(k, -1)
        if self.obstacles:
            block = np.empty((k, len(self._obs_pos), 4))
            offset = self._obs_pos[None, :, :] - own[:, None, :]
            block[:, :, 0], block[:, :, 1] = rotate(offset[:, :, 0], offset[:, :, 1])
            velocity = np.broadcast_to(self._obs_vel[None, :, :], offset.shape)
            block[:, :, 2], block[:, :, 3] = rotate(velocity[:, :, 0], velocity[:, :, 1])
            out[:, s["obstacles_local"]] = block.reshape(k, -1)

    def _metrics(self, agent: str) -> dict[str, Any]:
        i = self._index[agent]
        metrics = {
            "arrived": bool(self._arrived[i]),
            "distance_to_goal": float(self._goal_distance[i]),
            "path_length": float(self.robot_list[i].odometer),
            "collisions": int(self._collisions[i]),
            "min_clearance": float(self._min_clearance[i]),
            "min_center_distance": float(self._min_center[i]),
            "smoothness": float(self._smooth_sum[i] / self._smooth_steps[i]) if self._smooth_steps[i] else 0.0,
        }
        if self._arrived[i]:
            metrics["time_to_goal"] = float(self._arrival_time[i])
        return metrics

    def episode_success(self) -> bool:
        """Every robot has reached its goal (collisions are counted in the metrics, not here)."""
        return self.world is not None and bool(self._arrived.all())

    # -- read-only views of the simulation, for analysis (copies; rows follow possible_agents) --
    @property
    def robot_positions(self) -> np.ndarray:
        """``(N, 2)`` robot centres (m) after the last step."""
        return self._pos.copy()

    @property
    def robot_headings(self) -> np.ndarray:
        """``(N,)`` robot headings θ (rad, in (−π, π])."""
        return self._theta.copy()

    @property
    def obstacle_positions(self) -> np.ndarray:
        """``(M, 2)`` obstacle centres (m)."""
        return self._obs_pos.copy()

    @property
    def obstacle_velocities(self) -> np.ndarray:
        """``(M, 2)`` obstacle velocities (m/s)."""
        return self._obs_vel.copy()

    @property
    def goal_distances(self) -> np.ndarray:
        """``(N,)`` distances from each robot to its goal (m)."""
        return np.linalg.norm(self.goals - self._pos, axis=1)

    def state(self) -> np.ndarray:
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        robots = np.column_stack([self._pos, self._theta, self._vel, self.goals]).ravel()
        obstacles = np.column_stack([self._obs_pos, self._obs_vel]).ravel() if self.obstacles else np.zeros(0)
        return np.concatenate([robots, obstacles]).astype(np.float32)

    def _overlay(self) -> Overlay:
        return Overlay(points=[(tuple(g), robot_colour(i)) for i, g in enumerate(self.goals)])


def parallel_env(render_mode: str | None = None, **config: Any) -> Navigation:
    """The PettingZoo parallel env (same as ``teamgym.make("Navigation-v0", ...)``)."""
    return Navigation(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any):
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
