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
(own frame with ``local_features``, else world axes); with ``virtual_forces`` then
``forces`` (5, 3): paper 001's virtual forces at the robot's pose (eqs. 15, 19, 21) from
its goal, team mates, obstacles (one step ahead), ray hits, and their sum, each as a unit
direction in the robot's frame and log(1 + |F|) (see ``NavigationConfig``). All three are
off by default (for RL).

This is the paper's "partially centralised sensory system": every robot knows the poses of
its team mates and the positions of the obstacles (section 2).

Actions (``action_type``): ``"velocity"`` continuous (v, ω); ``"wheels"`` continuous wheel
speeds; ``"heading"`` the discrete set of eq. (11), K = ``heading_levels`` angular
velocities with v from eqs. (12)–(13).

Actuation delay (section 6.1): with ``actuation_delay`` = T0 > 0 every robot keeps its
previous command for T0_true = ½ T0 (1 + δt) of each step. The paper calls δt ∈ [0, 1]
normally distributed; we draw δt ~ N(0.5, 0.25²) clipped to [0, 1]; ``true_delay="fixed"``
makes T0_true = T0. T0 may exceed Δt (up to 8Δt, beyond the paper's values): then a command
given at t_j acts from t_j + T0_true, a later step (a command queue; ``_delay_actuation``).

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
from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.control.heading import HeadingHeuristic, nearest_gap
from teamgym.envs.actions import ActionType, VelocityAction, WheelSpeedAction
from teamgym.envs.base import TeamEnv
from teamgym.envs.bounds import ROUNDING, SATURATION, region, speed_limits
from teamgym.envs.config import ConfigError
from teamgym.envs.infos import InfoKey, metrics, unknown
from teamgym.envs.navigation.actions import HeadingAction
from teamgym.envs.navigation.config import NavigationConfig
from teamgym.envs.navigation.phases import NavigationPhases
from teamgym.envs.navigation.scene import NavigationScene, PlacementError, scatter
from teamgym.envs.navigation.state import FORCE_ROWS, NavigationArrays, force_log_bound
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.sim.categories import SOLID, Category
from teamgym.sim.objects import MovingPolygon, regular_polygon
from teamgym.sim.render import Overlay, robot_colour
from teamgym.sim.robot import DiffDriveRobot, RobotSpec
from teamgym.sim.sensors import KHEPERA_RING, ProximityRing
from teamgym.sim.world import World

__all__ = ["Navigation", "NavigationConfig", "env", "parallel_env"]


class Navigation(TeamEnv):
    """Collision-free navigation among moving obstacles (paper 001). See the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "navigation_v0"}
    rebase_cycles = 400  # replaying 400 control cycles takes about 0.1-0.2 s (TeamEnv: copying and pickling)
    config_class = NavigationConfig
    config: NavigationConfig
    phases_class = NavigationPhases  # the step's phases over NavigationArrays rows, one numpy pass for a batch's copies

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
        self._use_rows(NavigationArrays(c, 1, self.ring.width), 0)

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
        """The fields of the module docstring with bounds from the config (:mod:`teamgym.envs.bounds`)."""
        c, spec = self.config, self.spec_robot
        n, m = c.n_robots, c.n_obstacles
        low, high = region(c, (c.arena_size, c.arena_size), c.walls, spec.max_wheel_speed)
        span = high - low  # largest offset between two bodies, per axis
        v, omega = speed_limits(c, spec)
        command = (spec.max_speed * (1 + ROUNDING), spec.max_turn_rate * (1 + ROUNDING))
        drift = SATURATION * c.body_speed()  # obstacles' speed readings
        # Goals lie in the square [0, A]²: a goal minus a position.
        goal_low, goal_high = -high, c.arena_size - low
        fields = [
            Field("pose", (3,), [*low, -math.pi], [*high, math.pi]),
            Field("velocity", (2,), [-v, -omega], [v, omega]),
            Field("last_command", (2,), [-command[0], -command[1]], list(command)),
            Field("radius", (1,), c.robot_radius, c.robot_radius),
            Field("goal_offset", (2,), goal_low, goal_high),
            Field("mates", (n - 1, 5), [*-span, -math.pi, -v, -omega], [*span, math.pi, v, omega]),
            Field("obstacles", (m, 5), [*-span, -drift, -drift, 0.0], [*span, drift, drift, c.obstacle_radius * (1 + ROUNDING)]),
            Field("proximity", (len(KHEPERA_RING),), 0.0, c.sensor_range),
        ]
        # Rotated into the robot's frame, a vector keeps its length.
        far, goal_far = float(np.hypot(*span)), float(np.hypot(*np.maximum(-goal_low, goal_high)))
        turned = float(np.hypot(drift, drift))
        if c.local_features:
            fields += [
                Field("goal_local", (2,), -goal_far, goal_far),
                Field("mates_local", (n - 1, 4), [-far, -far, -v, -v], [far, far, v, v]),
                Field("obstacles_local", (m, 4), [-far, -far, -turned, -turned], [far, far, turned, turned]),
            ]
        if c.mate_goals:
            local = c.local_features
            fields.append(Field("mate_goals", (n - 1, 2), -goal_far if local else goal_low, goal_far if local else goal_high))
        if c.virtual_forces:
            fields.append(
                Field("forces", (len(FORCE_ROWS), 3), [-1.0, -1.0, 0.0], [1.0, 1.0, force_log_bound(c, len(KHEPERA_RING))])
            )
        return ObservationLayout(fields)

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
        radii = np.array([o.bounding_radius for o in self.obstacles], dtype=float)
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        team, ks = self._arrays, self._copy_rows
        team.start(self._copy, goals, radii, [o.shape for o in self.obstacles])
        self.world.read_states()
        self._read_state()
        offset = team.goals[ks] - team.pos[ks]
        team.goal_distance[ks] = np.linalg.norm(offset, axis=2)
        team.update_distances(ks)
        self._read_proximity(np.arange(c.n_robots))

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

    # -- per-step state (this copy's rows of ``self._arrays``) ----------------------------
    def _use_rows(self, team: NavigationArrays, k: int) -> None:
        """Keep this env's per-step arrays in copy row ``k`` of ``team`` (a batch's; see :class:`NavigationArrays`)."""
        self._arrays, self._copy, self._copy_rows = team, k, slice(k, k + 1)

    def _episode_state(self) -> dict[str, Any]:
        """The base's, with this copy's rows of ``_arrays`` in place of the arrays (a batch's hold every copy)."""
        state = super()._episode_state()
        team, k = state.pop("_arrays"), state.pop("_copy")
        del state["_copy_rows"]
        rows = team.row(k)
        state["_team_rows"] = (rows, rows.pop("obstacle_shapes"))  # the key earlier releases' snapshots hold
        return state

    def _adopt_episode_state(self, state: dict[str, Any]) -> None:
        rows, shapes = state.pop("_team_rows")
        super()._adopt_episode_state(state)
        self._arrays.set_row(self._copy, {**rows, "obstacle_shapes": shapes})

    def _live_mask(self) -> np.ndarray:
        """``(1, N)``: which robots are in ``agents`` (shared and read-only, rebuilt when ``agents`` changes)."""
        rows = self._live_rows()
        if getattr(self, "_mask_rows", None) is not rows:
            mask = np.zeros((1, self.config.n_robots), dtype=bool)
            mask[0, rows] = True
            mask.flags.writeable = False
            self._mask_rows, self._mask = rows, mask
        return self._mask

    def _read_state(self) -> None:
        """Copy robot and obstacle states from the world's last batch read."""
        robots, movers = self.world.robot_states, self.world.mover_states
        if len(robots) != len(self.robot_list):
            robots, movers = self.world.read_states()
        self._arrays.read(self._copy_rows, robots[None], movers[None])

    def speed_inputs(self, agent: str) -> tuple[float, float]:
        """Inputs of the speed rule, eqs. (12)–(13): distance to the goal and L_min (m)."""
        i = self._index[agent]
        return float(self._arrays.goal_distance[self._copy, i]), self._nearest_for_speed(i)

    def _nearest_for_speed(self, i: int) -> float:
        """L_min,i of eq. (12), by :func:`teamgym.control.heading.nearest_gap` (``speed_rule``)."""
        c, team, k = self.config, self._arrays, self._copy
        return nearest_gap(
            team.object_offsets[k, i],
            team.object_gaps[k, i],
            float(team.theta[k, i]),
            team.proximity[k, i],
            self.ring.angles,
            c.sensor_range,
            c.speed_rule,
        )

    def _delay_actuation(self, robots: list[DiffDriveRobot], rng: np.random.Generator) -> None:
        """Section 6.1: each robot's true delay this step is ½ T0 (1 + δt), δt ~ N(0.5, 0.25²) in [0, 1].

        With ``true_delay="fixed"`` it is T0 in every step (no δt is drawn).

        T0 ≤ Δt: the robot keeps its previous command for the true delay, then runs the new
        one. T0 > Δt (up to ``MAX_DELAY_STEPS``·Δt): a command queue, the command given at t_j
        acts from t_j + delay (:meth:`~teamgym.sim.robot.DiffDriveRobot.lag_commands`); a robot
        that left the episode was given (0, 0).
        """
        config = self.config
        delay = config.actuation_delay
        if config.true_delay == "fixed":
            delays = [delay] * len(robots)
        else:
            delta = np.clip(rng.normal(0.5, 0.25, size=len(robots)), 0.0, 1.0)
            delays = [0.5 * delay * (1.0 + d) for d in delta.tolist()]
        if delay <= config.dt:
            for robot, d in zip(robots, delays):
                robot.actuation_delay = d
            return
        depth = math.floor(delay / config.dt + 1e-9) + 2
        for robot, d, live in zip(robots, delays, self._live_mask()[0].tolist()):
            robot.lag_commands(robot.command if live else (0.0, 0.0), d, config.dt, depth)

    def _terminations(self) -> dict[str, bool]:
        """A robot that arrives terminates, stops and stays in the world."""
        return dict(zip(self.live_agents, self._arrays.arrived[self._copy, self._live_rows()].tolist()))

    def _read_proximity(self, indices: np.ndarray, free: np.ndarray | None = None) -> None:
        """Ring readings of robots ``indices``; ``free`` flags robots known to have nothing within range (no rays cast)."""
        if len(indices) == 0:
            return
        robots = [self.robot_list[i] for i in indices.tolist()]
        block = np.empty((len(indices), self.ring.width), dtype=np.float32)
        flags = None if free is None else free.tolist()
        self.ring.read_rows(self.world, robots, self.world.robot_states[indices], self.np_random, block, flags)
        self._arrays.proximity[self._copy, indices] = block

    def _observe(self, out: np.ndarray) -> None:
        rows = self._live_rows()
        if len(rows) == 0:
            return
        if len(rows) == self.config.n_robots:  # everyone live: rows in order, straight into ``out``
            self._arrays.observe(self._copy_rows, self.layout, out[None])
            return
        every = np.empty((1, self.config.n_robots, out.shape[1]), dtype=out.dtype)
        self._arrays.observe(self._copy_rows, self.layout, every)
        out[:] = every[0, rows]

    def _info_keys(self) -> dict[str, InfoKey]:
        """Counts and distances from reset on; ``time_to_goal`` (s) NaN until the robot arrives."""
        keys = ("arrived", "distance_to_goal", "path_length", "collisions", "min_clearance", "min_center_distance", "smoothness")
        return {**metrics(*keys), **unknown("time_to_goal")}

    def _metrics(self, agent: str) -> dict[str, Any]:
        return self._metrics_of([agent])[agent]

    def _metrics_of(self, agents: list[str]) -> dict[str, dict[str, Any]]:
        """Every agent's metrics from this copy's rows, read once per step."""
        team, k = self._arrays, self._copy
        arrived, distance = team.arrived[k].tolist(), team.goal_distance[k].tolist()
        collisions, clearance, centre = team.collisions[k].tolist(), team.min_clearance[k].tolist(), team.min_center[k].tolist()
        smooth_sum, smooth_steps = team.smooth_sum[k].tolist(), team.smooth_steps[k].tolist()
        arrival = team.arrival_time[k].tolist()
        out = {}
        for agent in agents:
            i = self._index[agent]
            metrics = {
                "arrived": arrived[i],
                "distance_to_goal": distance[i],
                "path_length": float(self.robot_list[i].odometer),
                "collisions": collisions[i],
                "min_clearance": clearance[i],
                "min_center_distance": centre[i],
                "smoothness": smooth_sum[i] / smooth_steps[i] if smooth_steps[i] else 0.0,
            }
            if arrived[i]:
                metrics["time_to_goal"] = arrival[i]
            out[agent] = metrics
        return out

    def episode_success(self) -> bool:
        """Every robot has reached its goal (collisions are counted in the metrics, not here)."""
        return self.world is not None and bool(self._arrays.arrived[self._copy].all())

    # -- read-only views of the simulation, for analysis (copies; rows follow possible_agents) --
    @property
    def robot_positions(self) -> np.ndarray:
        """``(N, 2)`` robot centres (m) after the last step."""
        return self._arrays.pos[self._copy].copy()

    @property
    def robot_headings(self) -> np.ndarray:
        """``(N,)`` robot headings θ (rad, in (−π, π])."""
        return self._arrays.theta[self._copy].copy()

    @property
    def obstacle_positions(self) -> np.ndarray:
        """``(M, 2)`` obstacle centres (m)."""
        return self._arrays.obs_pos[self._copy].copy()

    @property
    def obstacle_velocities(self) -> np.ndarray:
        """``(M, 2)`` obstacle velocities (m/s)."""
        return self._arrays.obs_vel[self._copy].copy()

    @property
    def goal_distances(self) -> np.ndarray:
        """``(N,)`` distances from each robot to its goal (m)."""
        return np.linalg.norm(self.goals - self._arrays.pos[self._copy], axis=1)

    def state(self) -> np.ndarray:
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        team, k = self._arrays, self._copy
        robots = np.column_stack([team.pos[k], team.theta[k], team.vel[k], self.goals]).ravel()
        obstacles = np.column_stack([team.obs_pos[k], team.obs_vel[k]]).ravel() if self.obstacles else np.zeros(0)
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
