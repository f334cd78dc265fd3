"""``Foraging-v0``: consuming and surrounding with limited perception and a lossy radio (paper 002).

``n_robots`` Viper-sized robots search a walled field (the RoboCup small-size field, 3.0 m ×
2.4 m by default) for ``n_targets`` static targets placed at random. Each robot sees only
through a forward camera (``camera_range`` 1 m, ``camera_fov`` 73°) that other robots occlude,
knows its own pose only through odometry whose error grows with rotation and resets at a
landmark sighting (:mod:`teamgym.envs.foraging.perception`), and shares what it sees over the
core radio: every control step (or ``packet_rate`` times per second) each live robot broadcasts
a packet of perception tuples ``(class, gx, gy, Pc)`` — its own location first — delivered
with probability ``comm_throughput`` (section 2.1). Tasks (section 4.1, :class:`ForagingConfig`):
``consume`` (a robot stays at a target for ``consume_time``; the target then disappears, or with
``consumed_targets="persist"`` stays, looking like any target, and cannot be consumed again) and
``surround`` (``robots_per_target`` robots at a target at once).

Observation fields (``env.decode(obs)``; ``obs_format="dict"`` gives them as a Dict), with
D = n_targets + n_robots − 1 detection slots and R = (n_robots − 1)(1 + D) received tuples:

==========================  ============  =====  ============================================
field                       shape         dtype  meaning
==========================  ============  =====  ============================================
``pose_estimate``           (3,)          f32    odometry estimate x̂, ŷ (m), θ̂ (rad)
``localisation_certainty``  (1,)          f32    Pl (eq. 2)
``detections``              (D, 4)        f32    own tuples (class, gx, gy, Pc), targets first
``detection_polar``         (D, 2)        f32    their measured distance (m) and bearing (rad)
``detection_mask``          (D,)          int8   1 for a detection, 0 for padding
``received``                (R, 4)        f32    tuples received this step (packets in order)
``received_sender``         (R,)          int32  sender's index in ``possible_agents``, −1 pad
``received_mask``           (R,)          int8   1 for a received tuple
``at_target``               (1,)          int8   within ``reach_radius`` of a live target
                                                 (``persist``: of any target)
``consume_progress``        (1,)          f32    time at the current target / ``consume_time``
``world_model``             (2, ny, nx)   f32    optional (``observe_world_model``): the
                                                 robot's fused grid model (targets, robots)
``novelty``                 (ny, nx)      f32    optional (``observe_novelty``): per cell
                                                 1 − exp(−age / ``novelty_time``), age = time
                                                 since the robot's model last saw it (never: 1)
==========================  ============  =====  ============================================

Actions: ``goto_cell`` (default; :class:`~teamgym.envs.foraging.actions.GoToCellAction`, a cell
index driven to by :class:`~teamgym.envs.foraging.controller.GoToController`, with a mask) or
``velocity`` (continuous (v, ω)). ``comm_dim`` adds a learned message (same channel).

Rewards (team, every robot): ``consume_reward`` per (live) target finished in the step,
``progress_reward`` × the decrease of the robot's distance to its nearest live target (m),
− ``time_penalty``. Metrics in ``infos[agent]`` (section 4.5): ``TL`` (s, once any robot has
seen a target), ``TT1``.. ``TTn`` (s, the k-th target finished), ``TG`` (s, on success), ``DG``
(m travelled by this robot), ``targets_done``, ``localisation_certainty``, ``position_error``
(m, estimate vs truth), with ``persist`` ``redundant`` (operations this robot completed at
targets already consumed), and the channel counters ``bytes_sent``, ``bytes_delivered``, ...
Reset options fix a scene: ``{"targets": [(x, y), ...], "starts": [(x, y, θ), ...]}``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv

from teamgym.envs.actions import ActionType, VelocityAction
from teamgym.envs.base import TeamEnv
from teamgym.envs.config import ConfigError
from teamgym.envs.foraging.actions import GoToCellAction
from teamgym.envs.foraging.config import ForagingConfig
from teamgym.envs.foraging.controller import GoToController
from teamgym.envs.foraging.perception import ROBOT, SENDER, Odometry, VisionModel, landmark_positions, packet_bytes
from teamgym.envs.foraging.sensing import POLAR, TARGET_CELL, TUPLE, Cameras, perceive
from teamgym.envs.infos import InfoKey, metrics, unknown
from teamgym.envs.reset_input import scene_points
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.sim.objects import Target
from teamgym.sim.render import Overlay
from teamgym.sim.robot import DiffDriveRobot
from teamgym.sim.world import World

__all__ = ["Foraging", "env", "novelty", "packet_due", "parallel_env"]

#: Channel message kind of the perception packets.
PACKET_KIND = "perception"
_PLACEMENT_TRIES = 2000


def packet_due(k: int, share: float) -> bool:
    """Whether sensing phase ``k`` (0 at reset) sends at ``share`` packets per control step: ⌊k·share⌋ steps up at k.

    Phase 0 sends iff ``share > 0``; ``share = 1`` sends at every phase (see ``ForagingConfig.packet_rate``).
    """
    if k == 0:
        return share > 0
    return math.floor(k * share + 1e-9) > math.floor((k - 1) * share + 1e-9)


def novelty(now: float, last_seen: np.ndarray, novelty_time: float) -> np.ndarray:
    """``1 − exp(−(now − last_seen) / novelty_time)`` per cell; never seen (``last_seen = −inf``): 1.

    The novelty term of DMAPS's search field (``baselines.foraging.potential``), from one robot's
    :class:`~teamgym.envs.foraging.world_model.GridWorldModel` ``last_seen`` (s).
    """
    return -np.expm1(-(now - last_seen) / novelty_time)


class Foraging(TeamEnv):
    """Consume or surround targets with a camera, odometry and a lossy radio; see the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "foraging_v0"}
    config_class = ForagingConfig
    reset_option_keys = ("targets", "starts")
    uses_channel = True
    config: ForagingConfig
    pixels_per_metre = 160.0

    # -- construction ------------------------------------------------------------------------
    def _agent_names(self) -> list[str]:
        return [f"robot_{i}" for i in range(self.config.n_robots)]

    def _setup(self) -> None:
        c = self.config
        self.grid = c.grid
        self.spec = c.robot_spec
        self.vision = VisionModel(c.camera_range, c.camera_fov, c.vision_noise)
        self.landmarks = landmark_positions(*self.grid_size, c.landmark_spacing)
        self.controller = GoToController(self.spec.max_speed, self.spec.max_turn_rate, self.spec.radius)
        n = c.n_robots
        self.n_detections = c.n_targets + n - 1
        self.n_received = max(1, (n - 1) * (1 + self.n_detections))
        self.cameras = Cameras(n, self.landmarks, c.camera_range, c.camera_fov, self.spec.radius)
        self._cell_xy = self.grid.cell_at(np.arange(self.grid.n_cells))  # go-to cell -> (gx, gy)
        self._cell_centre = self.grid.centre_of(self._cell_xy)  # go-to cell -> its centre (m)
        self._packet_sizes = [packet_bytes(m, self.grid) for m in range(self.n_detections + 1)]
        self._slot_index = np.arange(self.n_detections)
        self._live_mask_rows: np.ndarray | None = None
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(3 * n + 3 * c.n_targets,), dtype=np.float32)

    @property
    def grid_size(self) -> tuple[float, float]:
        return float(self.config.field_size[0]), float(self.config.field_size[1])

    def _check_feasible(self) -> None:
        rng = np.random.default_rng(0)
        for _ in range(8):
            if self._draw_scene(rng) is not None:
                return
        raise ConfigError(
            f"ForagingConfig: could not place {self.config.n_robots} robots and {self.config.n_targets} targets "
            f"on a {self.config.field_size} m field (lower n_robots/n_targets/reach_radius or enlarge field_size)"
        )

    def _make_action_type(self) -> ActionType:
        if self.config.action_type == "velocity":
            return VelocityAction(self.spec)
        return GoToCellAction(self.grid, self.spec.radius)

    def _make_layout(self) -> ObservationLayout:
        c, (w, h) = self.config, self.grid_size
        top = max(self.grid.nx, self.grid.ny) - 1
        d, r = self.n_detections, self.n_received
        fields = [
            Field("pose_estimate", (3,), [-w, -h, -math.pi], [2 * w, 2 * h, math.pi]),
            Field("localisation_certainty", (1,), 0.0, 1.0),
            Field("detections", (d, 4), 0.0, [SENDER, top, top, 1.0]),
            Field("detection_polar", (d, 2), [0.0, -math.pi], [self.vision.max_distance, math.pi]),
            Field("detection_mask", (d,), 0, 1, np.int8),
            Field("received", (r, 4), 0.0, [SENDER, top, top, 1.0]),
            Field("received_sender", (r,), -1, c.n_robots - 1, np.int32),
            Field("received_mask", (r,), 0, 1, np.int8),
            Field("at_target", (1,), 0, 1, np.int8),
            Field("consume_progress", (1,), 0.0, 1.0),
        ]
        if c.observe_world_model:
            fields.append(Field("world_model", (2, *self.grid.shape), 0.0, 1.0))
        if c.observe_novelty:
            fields.append(Field("novelty", self.grid.shape, 0.0, 1.0))
        layout = ObservationLayout(fields)
        slices = layout.slices
        head = slice(slices["pose_estimate"].start, slices["localisation_certainty"].stop)
        self._fields = SimpleNamespace(head=head, **slices)  # where _observe writes each field of a flat row
        self._pose_low, self._pose_high = np.array([-w, -h]), np.array([2 * w, 2 * h])
        return layout

    # -- a new episode ------------------------------------------------------------------------
    def _draw_scene(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray] | None:
        """Targets (T, 2) and starts (n, 3) drawn apart, or None if they do not fit."""
        c, r = self.config, self.spec.radius
        (w, h), margin = self.grid_size, r + 0.02
        starts = np.zeros((c.n_robots, 3))
        for i in range(c.n_robots):
            for _ in range(_PLACEMENT_TRIES):
                p = rng.uniform((margin, margin), (w - margin, h - margin))
                if np.all(np.hypot(*(starts[:i, :2] - p).T) >= 3 * r):
                    break
            else:
                return None
            starts[i] = (p[0], p[1], rng.uniform(-math.pi, math.pi))
        targets = np.zeros((c.n_targets, 2))
        edge = min(c.reach_radius, 0.5 * min(w, h))
        for j in range(c.n_targets):
            for _ in range(_PLACEMENT_TRIES):
                p = rng.uniform((0.5 * edge, 0.5 * edge), (w - 0.5 * edge, h - 0.5 * edge))
                apart = np.all(np.hypot(*(targets[:j] - p).T) >= 2 * c.reach_radius)
                if apart and np.all(np.hypot(*(starts[:, :2] - p).T) > c.reach_radius + r):
                    break
            else:
                return None
            targets[j] = p
        return targets, starts

    def _build(self, rng: np.random.Generator) -> None:
        c = self.config
        scene = self._draw_scene(rng)
        if scene is None:
            raise ConfigError("ForagingConfig: the scene could not be placed (see make()'s feasibility check)")
        targets, starts = scene
        targets = self.reset_options.get("targets", targets)
        starts = self.reset_options.get("starts", starts)
        self.world = World(self.grid_size, **c.world_options())
        self.world.add_boundary()
        self.robots = {
            a: self.world.add(DiffDriveRobot(a, (x, y), th, self.spec)) for a, (x, y, th) in zip(self.possible_agents, starts)
        }
        self.targets = targets.copy()
        self._target_names = [f"target_{j}" for j in range(c.n_targets)]
        for name, xy in zip(self._target_names, targets):
            self.world.add(Target(name, tuple(xy), radius=0.04))
        n, t = c.n_robots, c.n_targets
        self.target_live = np.ones(t, dtype=bool)
        self._live_targets = np.arange(t)
        self._persist = c.consumed_targets == "persist"
        self._all_targets = np.arange(t)  # what the cameras see and the robots may stand at (persist)
        self._redundant = np.zeros(n, dtype=np.int64)
        self._senses = 0  # sensing phases since reset (the packet schedule of packet_rate)
        self.target_done_at = np.full(t, np.nan)
        self._done_order: list[float] = []
        self._first_seen = math.nan
        self._no_target, self._zero_timer = np.full(n, -1), np.zeros(n)  # shared, never written to
        self._timer, self._at = self._zero_timer, self._no_target
        self._travelled = np.zeros(n)
        self._finished_now = 0
        self.world.read_states()
        self._pose = self._read_pose()
        self.odometry = Odometry(self._pose, c.rotational_certainty, c.odometry_rotation_noise, c.odometry_distance_noise)
        self._heading_trig = (np.cos(self._pose[:, 2]), np.sin(self._pose[:, 2]))
        self._points = self.cameras.points(self.targets)
        self._geometry = self.cameras.view(self._pose, self._points)
        self._update_presence()
        self._nearest = self._nearest_target_distance()
        self._success = False
        self.models = {}
        if c.keeps_world_models:
            from teamgym.envs.foraging.world_model import GridWorldModel, ViewSector

            self._view = ViewSector(self.grid, c.camera_range, c.camera_fov)
            self.models = {a: GridWorldModel(self.grid, n, i) for i, a in enumerate(self.possible_agents)}
        self._sense()

    def _check_reset_options(self, options: dict) -> dict:
        """``targets`` ``(n_targets, 2)`` and ``starts`` ``(n_robots, 3)``: points in the field (starts a radius inside)."""
        c, size = self.config, self.grid_size
        shapes = {"targets": ((c.n_targets, 2), 0.0), "starts": ((c.n_robots, 3), self.spec.radius)}
        return {key: scene_points(key, value, shapes[key][0], size, shapes[key][1]) for key, value in options.items()}

    # -- step phases --------------------------------------------------------------------------
    def _read_pose(self) -> np.ndarray:
        states = self.world.robot_states
        pose = states[:, :3].copy()
        pose[:, 2] = (pose[:, 2] + math.pi) % (2 * math.pi) - math.pi
        return pose

    def _rows_of(self, agents: list[str]) -> tuple[np.ndarray, bool]:
        """Rows (``possible_agents`` order) of ``agents`` and whether they are every robot in order."""
        if agents == self.live_agents:
            self._live_mask()
            return self._live_rows(), self._everyone
        rows = np.fromiter((self._row[a] for a in agents), dtype=np.int64, count=len(agents))
        return rows, len(rows) == self.config.n_robots and bool(np.all(rows == np.arange(len(rows))))

    def _live_mask(self) -> np.ndarray:
        """(n,) bool: the robots in ``live_agents`` (rebuilt only when they change)."""
        rows = self._live_rows()
        if self._live_mask_rows is not rows:
            self._live_mask_rows = rows
            self._live_flags = np.zeros(self.config.n_robots, dtype=bool)
            self._live_flags[rows] = True
            self._everyone = len(rows) == self.config.n_robots and bool(np.all(rows == np.arange(len(rows))))
        return self._live_flags

    def goto_commands(self, cells: dict[str, int]) -> dict[str, tuple[float, float]]:
        """Control phase of ``goto_cell``: every acting robot's ``(v, ω)`` for its go-to cell."""
        agents = list(cells)
        rows, everyone = self._rows_of(agents)
        index = np.fromiter(cells.values(), dtype=np.int64, count=len(agents))
        goal = self._cell_xy[index]
        pose, estimate, at, (c, s) = self._pose, self.odometry.estimate, self._at, self._heading_trig
        table = self._sightings.table
        if not everyone:
            pose, estimate, at, c, s, table = pose[rows], estimate[rows], at[rows], c[rows], s[rows], table[rows]
        # Homing: the detected target nearest (in cells) to the go-to cell, if within one cell of it.
        homing = None
        if self._sightings.any_target:
            gap = np.maximum.reduce(np.abs(table[:, 1:, TARGET_CELL] - goal[:, None, :]), axis=2)
            close = np.minimum.reduce(gap, axis=1) <= 1
            if np.count_nonzero(close):
                homing = table[np.arange(len(table)), 1 + np.argmin(gap, axis=1), POLAR].astype(float)
                homing[~close] = np.nan
        # Stop at a target when the go-to cell is within one cell of the robot's estimated cell
        # (persist: while the robot's own operation there is unfinished).
        stop = None
        present = at >= 0
        if self._persist and self.config.task == "consume":  # a robot whose own operation there is done is not held
            present &= (self._timer if everyone else self._timer[rows]) < self.config.consume_time - 1e-9
        if np.count_nonzero(present):  # (the own cell of the last packet is the estimated cell now)
            stop = present & (np.maximum.reduce(np.abs(table[:, 0, 1:3] - goal), axis=1) <= 1)
        commands = self.controller.commands(estimate, pose, self._cell_centre[index], homing, stop, self.grid_size, (c, s))
        return dict(zip(agents, map(tuple, commands.tolist())))

    def _update_state(self) -> None:
        """State phase: true poses, odometry, distance travelled, who is at which target."""
        before, (c, s) = self._pose, self._heading_trig
        self._pose = self._read_pose()
        n = len(before)
        angles = np.concatenate([self.odometry.estimate[:, 2], self._pose[:, 2]])
        cos, sin = np.cos(angles), np.sin(angles)
        self._heading_trig = (cos[n:], sin[n:])
        step = self.odometry.advance(before, self._pose, self.np_random, (c, s, cos[:n], sin[:n]))
        self._travelled += np.hypot(step[:, 0], step[:, 1])
        self._geometry = self.cameras.view(self._pose, self._points)
        self._update_presence()

    def _update_presence(self) -> None:
        """``_at[i]``: the live target robot i is within ``reach_radius`` of (nearest), −1 if none; ``_nearest_live``
        each robot's distance to its nearest live target."""
        live = self._live_targets
        if not len(live):
            self._nearest_live = None
            at = self._no_target
        else:
            gap = self._geometry.distance[:, : self.config.n_targets]
            if len(live) < self.config.n_targets:
                gap = gap[:, live]
            self._nearest_live = nearest = np.minimum.reduce(gap, axis=1)
            reached = nearest <= self.config.reach_radius
            at = np.where(reached, live[np.argmin(gap, axis=1)], -1) if np.count_nonzero(reached) else self._no_target
        if self._persist and len(live) < self.config.n_targets:  # a consumed target still holds a robot
            gap = self._geometry.distance[:, : self.config.n_targets]
            nearest = np.minimum.reduce(gap, axis=1)
            reached = nearest <= self.config.reach_radius
            at = np.where(reached, np.argmin(gap, axis=1), -1) if np.count_nonzero(reached) else self._no_target
        if at is self._no_target:  # no robot at a target: every timer restarts
            self._timer = self._zero_timer
        else:
            self._timer = np.where((at >= 0) & (at == self._at), self._timer, 0.0)
        self._at = at

    def _check_goals(self) -> None:
        """Goals phase: consume (a robot stayed ``consume_time``) or surround (enough robots at once)."""
        c, now = self.config, self.world.time
        self._finished_now = 0
        present = self._at >= 0
        if not np.count_nonzero(present):
            self._success = not len(self._live_targets)
            return
        if c.task == "consume":
            self._timer[present] += c.dt
            finished = present & (self._timer >= c.consume_time - 1e-9) & self._live_mask()
            if self._persist and np.count_nonzero(finished):  # at a consumed target: a redundant operation
                self._redundant += finished & ~self.target_live[self._at] & (self._timer < c.consume_time + 0.5 * c.dt - 1e-9)
                finished &= self.target_live[self._at]
            done = np.unique(self._at[finished]) if np.count_nonzero(finished) else ()
        else:
            counts = np.bincount(self._at[present & self._live_mask()], minlength=c.n_targets)
            done = np.flatnonzero((counts >= c.robots_per_target) & self.target_live)
        if len(done):
            for j in done.tolist():
                self._finish_target(j, now)
            self._update_presence()
        self._success = not len(self._live_targets)

    def _finish_target(self, j: int, now: float) -> None:
        self.target_live[j] = False
        self._live_targets = np.flatnonzero(self.target_live)
        self.target_done_at[j] = now
        self._done_order.append(now)
        self._finished_now += 1
        if not self._persist:
            self.world.remove(self._target_names[j])

    def _nearest_target_distance(self) -> np.ndarray:
        return np.zeros(len(self._pose)) if self._nearest_live is None else self._nearest_live

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        c = self.config
        before, self._nearest = self._nearest, self._nearest_target_distance()
        progress = 0.0 if self._finished_now else before - self._nearest
        gain = c.consume_reward * self._finished_now + c.progress_reward * progress - c.time_penalty
        self._live_mask()
        if self._everyone:
            total += gain
        else:
            rows = self._live_rows()
            total[rows] += gain if np.ndim(gain) == 0 else gain[rows]

    def _sense(self) -> None:
        """Sensing phase: camera (targets, robots, landmarks), re-localisation, tuples; packets go on the radio."""
        self._sightings = perceive(
            self.cameras,
            self.grid,
            self.vision,
            self.odometry,
            self._pose,
            self._geometry,
            self._all_targets if self._persist else self._live_targets,
            self._live_mask(),
            self.n_detections,
            self.np_random,
        )
        if self._sightings.any_target and not math.isfinite(self._first_seen):
            self._first_seen = self.world.time
        self._send_packets()

    def _send_packets(self) -> None:
        """Every live robot broadcasts its location tuple and detections (section 4.3), at ``packet_rate``."""
        rate, k = self.config.packet_rate, self._senses
        self._senses += 1
        if rate is not None and not packet_due(k, rate * self.config.dt):
            return
        sightings, sizes, send = self._sightings, self._packet_sizes, self.channel.send_array
        count = sightings.count.tolist()
        for agent, i in zip(self.live_agents, self._live_rows().tolist()):
            send(agent, sightings.packet(i), sizes[count[i]], PACKET_KIND)

    def _received(self, agent: str) -> tuple[np.ndarray, np.ndarray]:
        """Tuples (m, 4) and their senders' indices (m,) delivered to ``agent`` this step."""
        packets = self.channel.inbox_payloads(agent, PACKET_KIND)
        if not packets:
            return np.zeros((0, 4), dtype=np.float32), np.zeros(0, dtype=np.int32)
        if len(packets) == 1:
            sender, payload = packets[0]
            tuples = payload.reshape(-1, 4)[: self.n_received]
            return tuples, np.full(len(tuples), sender, dtype=np.int32)
        tuples = np.concatenate([payload for _, payload in packets]).reshape(-1, 4)[: self.n_received]
        senders = np.repeat(np.array([s for s, _ in packets], dtype=np.int32), [len(p) // 4 for _, p in packets])
        return tuples, senders[: self.n_received]

    def _terminations(self) -> dict[str, bool]:
        return dict.fromkeys(self.live_agents, self._success)

    # -- outputs ------------------------------------------------------------------------------
    def _observe(self, out: np.ndarray) -> None:
        c, fields = self.config, self._fields
        rows = self._live_rows()
        self._live_mask()
        table, count, odometry = self._sightings.table, self._sightings.count, self.odometry
        estimate, certainty, at, timer = odometry.estimate, odometry.certainty, self._at, self._timer
        if not self._everyone:
            table, count, estimate, certainty, at, timer = (
                table[rows],
                count[rows],
                estimate[rows],
                certainty[rows],
                at[rows],
                timer[rows],
            )
        head = out[:, fields.head]  # pose_estimate, localisation_certainty
        head[:, :2] = np.minimum(np.maximum(estimate[:, :2], self._pose_low), self._pose_high)
        head[:, 2] = estimate[:, 2]
        head[:, 3] = certainty
        n = len(out)
        out[:, fields.detections].reshape(n, -1, 4)[:] = table[:, 1:, TUPLE]
        out[:, fields.detection_polar].reshape(n, -1, 2)[:] = table[:, 1:, POLAR]
        out[:, fields.detection_mask] = self._slot_index < count[:, None]
        out[:, fields.at_target] = at[:, None] >= 0
        if c.task == "consume":
            out[:, fields.consume_progress] = np.minimum(1.0, timer[:, None] / c.consume_time)
        out[:, fields.received_sender] = -1
        for obs, agent, i in zip(out, self.live_agents, rows.tolist()):
            tuples, senders = self._received(agent)
            k = len(tuples)
            if k:
                obs[fields.received][: 4 * k] = tuples.reshape(-1)
                obs[fields.received_sender][:k] = senders
                obs[fields.received_mask][:k] = 1
            if c.keeps_world_models:
                model = self.models[agent]
                m = int(self._sightings.count[i])
                model.observe_own(self._sightings.detections[i, :m], self._sector(i), self.world.time)
                for sender in np.unique(senders).tolist():
                    model.receive(sender, tuples[senders == sender], self.world.time)
                if c.observe_world_model:
                    self.layout.view(obs, "world_model")[:] = model.fused()
                if c.observe_novelty:
                    self.layout.view(obs, "novelty")[:] = novelty(self.world.time, model.last_seen, c.novelty_time)

    def _sector(self, i: int) -> np.ndarray:
        """Cells robot i sees now by its estimate: the camera's sector minus the shadows of the robots in view."""
        x, y, theta = self.odometry.estimate[i]
        seen = self.grid.sector_mask(x, y, theta, self.config.camera_range, self.config.camera_fov)
        detections = self._sightings.detections[i]
        robots = (detections[:, 0] == ROBOT) & (self._slot_index < self._sightings.count[i])
        if robots.any():
            seen &= ~self._view.shadow(x, y, theta, self._sightings.polar[i, robots], self.spec.radius)
        return seen

    def _info_keys(self) -> dict[str, InfoKey]:
        """``TL`` (first target seen), ``TT1``..``TTn`` (k-th target done) and ``TG`` (success), in s, NaN until then;
        ``DG``, ``targets_done``, ``localisation_certainty``, ``position_error`` from reset on."""
        times = ("TL", *(f"TT{k}" for k in range(1, self.config.n_targets + 1)), "TG")
        extra = ("redundant",) if self.config.consumed_targets == "persist" else ()
        return {**unknown(*times), **metrics("DG", "targets_done", "localisation_certainty", "position_error", *extra)}

    def _metrics(self, agent: str) -> dict[str, Any]:
        return self._metrics_of([agent])[agent]

    def _metrics_of(self, agents: list[str]) -> dict[str, dict[str, Any]]:
        team: dict[str, Any] = {}
        if math.isfinite(self._first_seen):
            team["TL"] = self._first_seen
        for k, time in enumerate(self._done_order, start=1):
            team[f"TT{k}"] = time
        if self._success:
            team["TG"] = self._done_order[-1]
        offset = self.odometry.estimate[:, :2] - self._pose[:, :2]
        errors = np.hypot(offset[:, 0], offset[:, 1]).tolist()
        travelled, certainty = self._travelled.tolist(), self.odometry.certainty.tolist()
        done, out = len(self._done_order), {}
        for agent in agents:
            i = self._row[agent]
            out[agent] = {
                **team,
                "DG": travelled[i],
                "targets_done": done,
                "localisation_certainty": certainty[i],
                "position_error": errors[i],
            }
            if self._persist:
                out[agent]["redundant"] = int(self._redundant[i])
        return out

    def episode_success(self) -> bool:
        """Every target consumed (``consume``) or surrounded (``surround``)."""
        return self.world is not None and self._success

    def state(self) -> np.ndarray:
        """True x, y, θ of every robot, then x, y, live (0/1) of every target (see ``state_space``)."""
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        targets = np.column_stack([self.targets, self.target_live.astype(float)])
        return np.concatenate([self._pose.ravel(), targets.ravel()]).astype(np.float32)

    def _overlay(self) -> Overlay:
        c, overlay = self.config, Overlay()
        for point in self.landmarks:
            overlay.points.append((tuple(point), (90, 90, 90)))
        arc = np.linspace(-0.5 * c.camera_fov, 0.5 * c.camera_fov, 9)
        for agent in self.live_agents:
            x, y, theta = self._pose[self._row[agent]]
            edge = [(x + c.camera_range * math.cos(theta + a), y + c.camera_range * math.sin(theta + a)) for a in arc]
            overlay.paths.append(([(x, y), *edge, (x, y)], (170, 170, 220)))
        return overlay


def parallel_env(render_mode: str | None = None, **config: Any) -> Foraging:
    """The PettingZoo parallel env; ``config`` holds :class:`ForagingConfig` keys."""
    return Foraging(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any) -> AECEnv:
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
