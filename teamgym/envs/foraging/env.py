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
                                                 robot's fused grid model (targets, robots);
                                                 ``world_model_sources="own"``: its own
                                                 sightings only
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
from teamgym.envs.foraging.perception import PACKET_KIND, ROBOT, SENDER, Odometry, VisionModel, landmark_positions, packet_bytes
from teamgym.envs.foraging.phases import ForagingPhases
from teamgym.envs.foraging.sensing import POLAR, TARGET_CELL, TUPLE, Cameras, Geometry, Sightings, perceive
from teamgym.envs.foraging.state import ForagingArrays
from teamgym.envs.infos import InfoKey, metrics, unknown
from teamgym.envs.reset_input import scene_points
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.sim.objects import Target
from teamgym.sim.render import Overlay
from teamgym.sim.robot import DiffDriveRobot
from teamgym.sim.world import World

__all__ = ["Foraging", "env", "novelty", "packet_due", "parallel_env"]

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
    phases_class = ForagingPhases  # the step's phases, bound to ForagingArrays rows (a batch's shared ones)
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
        self._cell_of_index = [tuple(cell) for cell in self._cell_xy.tolist()]
        self._cell_centres = [tuple(centre) for centre in self._cell_centre.tolist()]
        self._packet_sizes = [packet_bytes(m, self.grid) for m in range(self.n_detections + 1)]
        self._slot_index = np.arange(self.n_detections)
        self._live_mask_rows: np.ndarray | None = None
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(3 * n + 3 * c.n_targets,), dtype=np.float32)
        self._use_rows(ForagingArrays(n, c.n_targets, self.n_detections), 0)
        self._target_names = [f"target_{j}" for j in range(c.n_targets)]
        self._persist = c.consumed_targets == "persist"
        self._all_targets = np.arange(c.n_targets)  # what the cameras see and the robots may stand at (persist)
        self._all_targets.flags.writeable = False
        if c.keeps_world_models:
            from teamgym.envs.foraging.world_model import ViewSector

            self._view = ViewSector(self.grid, c.camera_range, c.camera_fov)

    # -- per-episode state (this copy's row of ``self._arrays``, see teamgym.envs.foraging.state) ---------------
    #: Attributes that are views of the row (written in place): env attribute -> ForagingArrays name.
    _ROW_VIEWS = {
        "_pose": "pose",
        "_travelled": "travelled",
        "_at": "at",
        "_timer": "timer",
        "_redundant": "redundant",
        "_nearest": "nearest",
        "_nearest_live": "nearest_live",
        "targets": "targets",
        "target_live": "target_live",
        "target_done_at": "target_done_at",
    }

    def _use_rows(self, arrays: ForagingArrays, k: int) -> None:
        """Keep this env's episode state in copy row ``k`` of ``arrays`` (a batch's shared ones, or its own)."""
        self._arrays, self._copy = arrays, k
        for attribute, name in self._ROW_VIEWS.items():
            setattr(self, attribute, getattr(arrays, name)[k])
        if "odometry" in self.__dict__:
            self._bind_odometry()
        if "_sightings" in self.__dict__:
            self._sightings = Sightings(arrays.table[k], arrays.count[k], bool(arrays.any_target[k]))

    def _bind_odometry(self) -> None:
        """The odometry's estimate and certainty become (views of) this copy's row, keeping their values."""
        k, odometry = self._copy, self.odometry
        self._arrays.estimate[k], self._arrays.certainty[k] = odometry.estimate, odometry.certainty
        odometry.estimate, odometry.certainty = self._arrays.estimate[k], self._arrays.certainty[k]

    def _episode_state(self) -> dict[str, Any]:
        """The base's, with this copy's row of ``_arrays`` in place of the arrays and their views."""
        state = super()._episode_state()
        for attribute in (*self._ROW_VIEWS, "_sightings"):
            state.pop(attribute, None)
        arrays, k = state.pop("_arrays"), state.pop("_copy")
        state["_foraging_row"] = arrays.row(k)
        return state

    def _adopt_episode_state(self, state: dict[str, Any]) -> None:
        row = state.pop("_foraging_row", None)
        if row is None:  # a snapshot of a release that kept the episode in attributes
            row = _row_of_attributes(state)
        super()._adopt_episode_state(state)
        k, arrays = self._copy, self._arrays
        arrays.set_row(k, row)
        self._sightings = Sightings(arrays.table[k], arrays.count[k], bool(arrays.any_target[k]))
        self._use_rows(arrays, k)  # the snapshot's odometry held copies of the row

    def _team_value(name: str, kind: type) -> property:  # noqa: N805 (a helper run in the class body)
        def get(self: Foraging) -> Any:
            return kind(getattr(self._arrays, name)[self._copy])

        def put(self: Foraging, value: Any) -> None:
            getattr(self._arrays, name)[self._copy] = value

        return property(get, put, doc=f"This copy's ``ForagingArrays.{name}``.")

    _senses = _team_value("senses", int)
    _first_seen = _team_value("first_seen", float)
    _success = _team_value("success", bool)
    _finished_now = _team_value("finished_now", int)
    del _team_value

    @property
    def _done_order(self) -> list[float]:
        """The times (s) at which targets were finished, in order (``TT1``, ``TT2``, ...)."""
        return sorted(time for time in self.target_done_at.tolist() if time == time)

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
        self._observe_plan = self._make_observe_plan(layout.slices)
        return layout

    def _make_observe_plan(self, slices: dict[str, slice]) -> SimpleNamespace:
        """Where :meth:`_observe` writes: flat-row columns of the table's detection tuples and polar values (and their
        columns in a flat table row), then the columns of the scalar fields in the order it lists their values."""
        d, r, width = self.n_detections, self.n_received, 8  # a table row: TUPLE, POLAR, TARGET_CELL
        src = [width * (1 + slot) + col for slot in range(d) for col in range(TUPLE.start, TUPLE.stop)]
        dst = list(range(slices["detections"].start, slices["detections"].stop))
        src += [width * (1 + slot) + col for slot in range(d) for col in range(POLAR.start, POLAR.stop)]
        dst += list(range(slices["detection_polar"].start, slices["detection_polar"].stop))
        head = slices["pose_estimate"].start
        scalar = [head, head + 1, head + 2, slices["localisation_certainty"].start]
        scalar += list(range(slices["detection_mask"].start, slices["detection_mask"].stop))
        scalar.append(slices["at_target"].start)
        if self.config.task == "consume":
            scalar.append(slices["consume_progress"].start)
        scalar += list(range(slices["received_sender"].start, slices["received_sender"].stop))
        scalar += list(range(slices["received_mask"].start, slices["received_mask"].stop))
        (w, h) = self.grid_size
        return SimpleNamespace(
            table_src=np.array(src, dtype=np.intp),
            table_dst=np.array(dst, dtype=np.intp),
            scalar_dst=np.array(scalar, dtype=np.intp),
            low=(-w, -h),
            high=(2 * w, 2 * h),
            received=slices["received"],
            no_sender=[-1.0] * r,  # received_sender's padding
            ones=[1.0] * r,
            zeros=[0.0] * r,
        )

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
        k = self._copy
        self._arrays.start(k)
        self.targets[:] = targets
        for name, xy in zip(self._target_names, targets):
            self.world.add(Target(name, tuple(xy), radius=0.04))
        self._live_targets = self._all_targets  # derived from target_live (a new array when it changes)
        self.world.read_states()
        self._pose[:] = self._read_pose()
        self.odometry = Odometry(self._pose, c.rotational_certainty, c.odometry_rotation_noise, c.odometry_distance_noise)
        self._bind_odometry()
        self._points = self.cameras.points(self.targets)
        self._geometry = self.cameras.look(self._pose, self._points)
        self._update_presence()
        self._nearest[:] = self._nearest_live
        self.models = {}
        if c.keeps_world_models:
            from teamgym.envs.foraging.world_model import GridWorldModel

            self.models = {a: GridWorldModel(self.grid, c.n_robots, i) for i, a in enumerate(self.possible_agents)}
        self._sense()

    def _check_reset_options(self, options: dict) -> dict:
        """``targets`` ``(n_targets, 2)`` and ``starts`` ``(n_robots, 3)``: points in the field (starts a radius inside)."""
        c, size = self.config, self.grid_size
        shapes = {"targets": ((c.n_targets, 2), 0.0), "starts": ((c.n_robots, 3), self.spec.radius)}
        return {key: scene_points(key, value, shapes[key][0], size, shapes[key][1]) for key, value in options.items()}

    # -- step phases --------------------------------------------------------------------------
    def _read_pose(self) -> np.ndarray:
        return np.array(self._read_pose_rows(), dtype=float).reshape(-1, 3)

    def _read_pose_rows(self) -> list[tuple[float, float, float]]:
        """The robots' true poses from the world's last read, θ wrapped to [−π, π) (scalar, the same bits as numpy's)."""
        pi, two_pi = math.pi, 2 * math.pi
        return [(x, y, (a + pi) % two_pi - pi) for x, y, a in self.world.robot_states[:, :3].tolist()]

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
        index = list(cells.values())
        goals = [self._cell_of_index[i] for i in index]  # (gx, gy) of each go-to cell
        pose, estimate, at, timer = self._pose.tolist(), self.odometry.estimate.tolist(), self._at.tolist(), self._timer.tolist()
        table = self._sightings.table
        t, geometry = self.config.n_targets, self._view_geometry()
        mate_d, mate_x, mate_y = ([row[t : t + len(pose)] for row in part] for part in geometry[:3])  # teammates, as seen
        if not everyone:
            picked = rows.tolist()
            pose, estimate, at, timer = ([part[i] for i in picked] for part in (pose, estimate, at, timer))
            mate_x, mate_y, mate_d = ([[part[i][j] for j in picked] for i in picked] for part in (mate_x, mate_y, mate_d))
            table = table[rows]
        # Homing: the detected target nearest (in cells) to the go-to cell, if within one cell of it; its
        # measured distance and bearing as the table holds them (float32).
        homing = None
        if self._sightings.any_target:
            homing = []
            for detections, (gx, gy) in zip(table[:, 1:, POLAR.start : TARGET_CELL.stop].tolist(), goals):
                best = (math.inf, math.nan, math.nan)
                for d, b, cx, cy in detections:
                    gap = max(abs(cx - gx), abs(cy - gy))
                    if gap < best[0]:
                        best = (gap, d, b)
                homing.append(best[1:] if best[0] <= 1 else (math.nan, math.nan))
        # Stop at a target when the go-to cell is within one cell of the robot's estimated cell
        # (persist: while the robot's own operation there is unfinished).
        stop = None
        held = self._persist and self.config.task == "consume"  # a robot whose own operation there is done is not held
        done = self.config.consume_time - 1e-9
        present = [j >= 0 and not (held and time >= done) for j, time in zip(at, timer)]
        if any(present):  # (the own cell of the last packet is the estimated cell now)
            own = table[:, 0, 1:3].tolist()
            stop = [p and max(abs(x - gx), abs(y - gy)) <= 1 for p, (x, y), (gx, gy) in zip(present, own, goals)]
        aim = [self._cell_centres[i] for i in index]
        commands = self.controller.command_pairs(estimate, pose, aim, homing, stop, self.grid_size, (mate_x, mate_y, mate_d))
        return dict(zip(agents, commands))

    def _view_geometry(self) -> Geometry:
        """The cameras' view of the true poses (:meth:`Cameras.look`), computed again when a batch's pass left it unset."""
        geometry = self._geometry
        if geometry is None:
            geometry = self._geometry = self.cameras.look(self._pose, self._points)
        return geometry

    def _update_state(self) -> None:
        """State phase: true poses, odometry, distance travelled, who is at which target."""
        before, after = self._pose.tolist(), self._read_pose_rows()
        self._pose[:] = after
        step = self.odometry.advance_rows(before, after, self.np_random)
        self._travelled += np.hypot(*zip(*step))
        self._geometry = self.cameras.look(self._pose, self._points)
        self._update_presence()

    def _update_presence(self) -> None:
        """``_at[i]``: the live target robot i is within ``reach_radius`` of (nearest), −1 if none; ``_nearest_live``
        each robot's distance to its nearest live target."""
        live, reach, n_targets = self._live_targets, self.config.reach_radius, self.config.n_targets
        gaps = [row[:n_targets] for row in self._view_geometry().distance]  # robots x targets
        at = None
        if not len(live):
            self._nearest_live[:] = 0.0
        else:
            columns, nearest, at = live.tolist(), [], []
            for row in gaps:
                j = min(columns, key=row.__getitem__)  # the first nearest live target, as np.argmin picks it
                nearest.append(row[j])
                at.append(j if row[j] <= reach else -1)
            self._nearest_live[:] = nearest
        if self._persist and len(live) < n_targets:  # a consumed target still holds a robot
            at = [row.index(min(row)) if min(row) <= reach else -1 for row in gaps]
        if at is None or max(at) < 0:  # no robot at a target: every timer restarts
            self._timer[:], self._at[:] = 0.0, -1
            return
        before, timer = self._at.tolist(), self._timer.tolist()
        self._timer[:] = [t if j >= 0 and j == b else 0.0 for j, b, t in zip(at, before, timer)]
        self._at[:] = at

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
        self._finished_now += 1
        if not self._persist:
            self.world.remove(self._target_names[j])

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        c = self.config
        before = self._nearest.copy()
        self._nearest[:] = self._nearest_live
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
        sightings = perceive(
            self.cameras,
            self.grid,
            self.vision,
            self.odometry,
            self._pose.tolist(),
            self._view_geometry(),
            [True] * self.config.n_targets if self._persist else self.target_live.tolist(),
            self._live_mask().tolist(),
            self.n_detections,
            self.np_random,
            self._arrays.table[self._copy],
        )
        k, arrays = self._copy, self._arrays
        arrays.count[k], arrays.any_target[k] = sightings.count, sightings.any_target
        self._sightings = Sightings(sightings.table, arrays.count[k], sightings.any_target)
        if sightings.any_target and not math.isfinite(self._first_seen):
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

    def _deliver_messages(self) -> None:
        """Communication phase: deliver this step's packets; every robot is in the world, at its true pose."""
        if self.channel.busy:
            self.channel.deliver(self._pose[:, :2], self.np_random, self.cycles)

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
        """Every live robot's flat row: the table's detections in one gather, the scalar fields in one scatter."""
        c = self.config
        rows = self._live_rows()
        self._live_mask()
        sightings, odometry = self._sightings, self.odometry
        table = sightings.table
        est, cert, at, timer = odometry.estimate.tolist(), odometry.certainty.tolist(), self._at.tolist(), self._timer.tolist()
        count = sightings.count.tolist()
        if not self._everyone:
            picked = rows.tolist()
            est, cert, at, timer, count = ([part[i] for i in picked] for part in (est, cert, at, timer, count))
            table = table[rows]
        n = len(out)
        plan = self._observe_plan
        out[:, plan.table_dst] = table.reshape(n, -1)[:, plan.table_src]
        (low_x, low_y), (high_x, high_y) = plan.low, plan.high
        slots, consume, room = range(self.n_detections), c.task == "consume", self.n_received
        values = []
        for row, (agent, (x, y, theta), pl, m, j, time) in enumerate(zip(self.live_agents, est, cert, count, at, timer)):
            senders = self._write_received(agent, out[row])
            start = len(senders)
            value = [min(max(x, low_x), high_x), min(max(y, low_y), high_y), theta, pl]
            value += [1.0 if slot < m else 0.0 for slot in slots]
            value.append(1.0 if j >= 0 else 0.0)
            if consume:
                value.append(min(1.0, time / c.consume_time))
            value += senders
            value += plan.no_sender[: room - start]
            value += plan.ones[:start]
            value += plan.zeros[: room - start]
            values.append(value)
        out[:, plan.scalar_dst] = values
        if c.keeps_world_models:
            fuse_received = c.world_model_sources == "all"
            for obs, agent, i in zip(out, self.live_agents, rows.tolist()):
                model = self.models[agent]
                m = int(self._sightings.count[i])
                model.observe_own(self._sightings.detections[i, :m], self._sector(i), self.world.time)
                if fuse_received:
                    tuples, senders = self._received(agent)
                    for sender in np.unique(senders).tolist():
                        model.receive(sender, tuples[senders == sender], self.world.time)
                if c.observe_world_model:
                    self.layout.view(obs, "world_model")[:] = model.fused()
                if c.observe_novelty:
                    self.layout.view(obs, "novelty")[:] = novelty(self.world.time, model.last_seen, c.novelty_time)

    def _write_received(self, agent: str, row: np.ndarray) -> list[int]:
        """Write the tuples delivered to ``agent`` this step (the first ``n_received``, as :meth:`_received` gives them)
        into the ``received`` field of its flat observation ``row``; returns each tuple's sender."""
        room, at = self.n_received, self._observe_plan.received.start
        senders: list[int] = []
        start = 0
        for sender, payload in self.channel.inbox_payloads(agent, PACKET_KIND):
            k = min(len(payload) // 4, room - start)
            if k <= 0:
                break
            row[at + 4 * start : at + 4 * (start + k)] = payload[: 4 * k]
            senders += [sender] * k
            start += k
        return senders

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
        first_seen, order = self._first_seen, self._done_order
        if math.isfinite(first_seen):
            team["TL"] = first_seen
        for k, time in enumerate(order, start=1):
            team[f"TT{k}"] = time
        if self._success:
            team["TG"] = order[-1]
        offset = self.odometry.estimate[:, :2] - self._pose[:, :2]
        errors = np.hypot(offset[:, 0], offset[:, 1]).tolist()
        travelled, certainty = self._travelled.tolist(), self.odometry.certainty.tolist()
        done, out = len(order), {}
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


def _row_of_attributes(state: dict[str, Any]) -> dict[str, Any]:
    """The ``ForagingArrays`` row of a snapshot whose episode was kept in attributes (popped from ``state``)."""
    odometry, sightings = state["odometry"], state.pop("_sightings")
    nearest_live = state.pop("_nearest_live")
    row = {
        "pose": state.pop("_pose"),
        "estimate": odometry.estimate,
        "certainty": odometry.certainty,
        "travelled": state.pop("_travelled"),
        "at": state.pop("_at"),
        "timer": state.pop("_timer"),
        "redundant": state.pop("_redundant"),
        "nearest": state.pop("_nearest"),
        "nearest_live": 0.0 if nearest_live is None else nearest_live,
        "table": sightings.table,
        "count": sightings.count,
        "targets": state.pop("targets"),
        "target_live": state.pop("target_live"),
        "target_done_at": state.pop("target_done_at"),
        "senses": state.pop("_senses"),
        "first_seen": state.pop("_first_seen"),
        "success": state.pop("_success"),
        "finished_now": state.pop("_finished_now"),
        "any_target": sightings.any_target,
    }
    for name in ("_done_order", "_heading_trig", "_no_target", "_zero_timer"):  # derived now, or gone
        state.pop(name, None)
    return row


def parallel_env(render_mode: str | None = None, **config: Any) -> Foraging:
    """The PettingZoo parallel env; ``config`` holds :class:`ForagingConfig` keys."""
    return Foraging(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any) -> AECEnv:
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
