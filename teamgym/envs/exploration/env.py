"""Exploration-v0: a robot team explores an office of sectors and doors (paper 000).

``n_robots`` Khepera-like robots (default 3) start in sectors of a map (default the paper's
12-sector office ``office12``; any map file, see ``teamgym.maps``). Doors are open or closed
for the episode, sampled from their opening probabilities o_j (``door_states``), optionally
re-sampled every ``door_resample_period`` seconds or toggled with :meth:`Exploration.set_door`;
furniture stands in the rooms. A sector is explored when a robot enters it, i.e. when the
robot's place x_i becomes that sector (its centre is inside the sector and outside every
usable door circle, so a robot half-way through a door has not entered yet); the team
succeeds when every goal sector (``goal_sectors``, default all: M_G = V_S) is explored.

Action types (``action_type``):

* ``"velocity"``: continuous (v, ω) per control step, for RL;
* ``"operator"``: the paper's operators Wait(), FindDoor(D), TraverseDoor(D, S), GoTo(S1, S2)
  (:mod:`teamgym.envs.exploration.operators`) as macro actions. One ``step()`` is one planning
  stage (Fig. 5): every robot's operator runs on the behaviour-based controller
  (:mod:`teamgym.control.behaviour`) under the task-execution watcher
  (:mod:`teamgym.control.watcher`) until some robot completes or fails its task
  (``stage_end="any"``), or until every robot has (``"all"``). Giving a robot the operator it
  is still executing continues it. Preconditions are action masks in
  ``infos[agent]["action_mask"]`` (and ``env.action_mask(agent)``); a masked operator raises.

Observations (flat float32; ``env.decode(obs)``), with S sectors, D doors, V = S + D places
and N robots:

================  ============  ===============================================================
field             shape         meaning
================  ============  ===============================================================
``pose``          (3,)          own x, y (m), heading θ (rad)
``velocity``      (2,)          own v (m/s), ω (rad/s)
``sector``        (S,)          one-hot: the sector the robot is in
``place``         (V,)          one-hot: x_i, the robot's place (a door while inside its circle)
``proximity``     (8,)          Khepera ring distances (m), ``sensor_range`` if free
``mates_sector``  (N−1, S)      one-hot sectors of the team mates
``mates_place``   (N−1, V)      one-hot places of the team mates (the coordinator's state X)
``visited``       (S,)          M_V: explored sectors (shared by the coordinator)
``goal``          (S,)          M_G
``door_belief``   (D,)          o_j as the team knows it: the map's prior, 1/0 once a robot has
                                been inside the door's circle and seen it open/closed
``clutter``       (S,)          c_i as re-estimated from executed FindDoor tasks (eq. 2)
``task_status``   (4,)          one-hot watcher state: waiting, executing, completed, failed
``task``          (1,)          index of the robot's current operator (−1: none)
================  ============  ===============================================================

Reward per step, shared by the team: ``explore_reward`` per newly explored goal sector, minus
``time_penalty`` per control step; each robot also loses ``collision_penalty`` per contact.
Metrics in ``infos``: ``explored``, ``explored_fraction``, ``explored_all``, ``explore_time``
(s, once all are explored), ``path_length`` (own), ``team_path_length``, ``collisions``,
``sector``, ``place``; with operators also ``stages`` (planning stages until full exploration),
``tasks_completed``, ``tasks_failed``, ``task``, ``task_status``, ``task_reason`` and
``action_mask``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.control.poses import PoseRows
from teamgym.control.watcher import TASK_REASONS, WatcherState
from teamgym.envs.actions import ActionType, VelocityAction
from teamgym.envs.base import EpisodeOverError, TeamEnv
from teamgym.envs.bounds import region, speed_limits
from teamgym.envs.config import ConfigError
from teamgym.envs.exploration.config import ExplorationConfig, cached_map
from teamgym.envs.exploration.operators import OperatorAction, OperatorSet
from teamgym.envs.exploration.operators import _door_is_open as _door_is_open  # pickles of earlier releases name them here
from teamgym.envs.exploration.operators import _door_known_closed as _door_known_closed
from teamgym.envs.exploration.phases import ExplorationPhases
from teamgym.envs.exploration.state import ExplorationArrays
from teamgym.envs.infos import InfoKey, categorical, metrics, unknown
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.maps.build import map_entities
from teamgym.maps.model import OfficeMap
from teamgym.maps.topology import ClutterEstimate, TopologicalModel
from teamgym.sim.geometry import distance_to_polygon
from teamgym.sim.objects import Door
from teamgym.sim.render import Overlay
from teamgym.sim.robot import DiffDriveRobot, RobotSpec
from teamgym.sim.scene import StaticScene
from teamgym.sim.sensors import KHEPERA_RING, ProximityRing
from teamgym.sim.world import World

__all__ = ["Exploration", "ExplorationConfig", "env", "parallel_env"]

WATCHER_STATES = [s.name.lower() for s in WatcherState]


class Exploration(TeamEnv):
    """Multi-robot exploration of an office (paper 000). See the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "exploration_v0"}
    rebase_cycles = 600  # replaying 600 control cycles takes about 0.1-0.2 s (TeamEnv: copying and pickling)
    config_class = ExplorationConfig
    config: ExplorationConfig
    pixels_per_metre = 400.0
    phases_class = ExplorationPhases  # the step's phases over ExplorationArrays rows (one pass for a batch's copies)

    def _setup(self) -> None:
        self.operator_set = OperatorSet(self.map)
        self.operators = self.operator_set.operators
        c = self.config
        self.spec_robot = RobotSpec()
        self.ring = ProximityRing(KHEPERA_RING, c.sensor_range, c.sensor_noise)
        office = self.map
        self.n_sectors, self.n_doors = len(office.sectors), len(office.doors)
        self._rects = np.array([[s.x_min, s.y_min, s.x_max, s.y_max] for s in office.sectors])
        self._door_centres = np.array([d.centre for d in office.doors]).reshape(-1, 2)
        self._door_radii = np.array([d.radius for d in office.doors])
        eps = 1e-3  # m: a robot on a sector's border is in neither sector
        #: Per sector ``(x_min + ε, x_max − ε, y_min + ε, y_max − ε)``; per door ``(x, y, radius)``; as floats.
        self._sector_bounds = [(x0 + eps, x1 - eps, y0 + eps, y1 - eps) for x0, y0, x1, y1 in self._rects.tolist()]
        bounds = self._sector_bounds
        #: No point lies in two (shrunk) sectors, so a robot still in its sector needs no search.
        self._sectors_disjoint = not any(
            max(a[0], b[0]) < min(a[1], b[1]) and max(a[2], b[2]) < min(a[3], b[3])
            for k, a in enumerate(bounds)
            for b in bounds[k + 1 :]
        )
        self._door_discs = [(x, y, r) for (x, y), r in zip(self._door_centres.tolist(), self._door_radii.tolist())]
        #: The same as arrays for the phases over copies: ``(S, 4)`` shrunk sectors, ``(D, 3)`` door discs.
        self._bounds_array = np.array(self._sector_bounds, dtype=float).reshape(-1, 4)
        self._discs_array = np.array(self._door_discs, dtype=float).reshape(-1, 3)
        self._door_row = {d: j for j, d in enumerate(office.door_ids)}
        # Walls, doors and furniture, built once and placed in every episode's world first (teamgym.sim.scene).
        entities = map_entities(office, furniture=c.furniture, join_walls=True)
        self._scene = StaticScene(entities)
        #: The doors by id (the scene's; their state is drawn at every reset).
        self.doors: dict[str, Door] = {e.name: e for e in entities if isinstance(e, Door)}
        #: Bounding boxes ``(x_min, y_min, x_max, y_max)`` of the furniture, for the start checks.
        self._furniture_boxes = [
            (*np.min(f.vertices, axis=0).tolist(), *np.max(f.vertices, axis=0).tolist()) for f in office.furniture
        ]
        goals = c.goal_sectors or tuple(office.sector_ids)
        self.goal = np.array([s in goals for s in office.sector_ids])
        self._goal_list = self.goal.tolist()
        self._n_goals = int(np.count_nonzero(self.goal))
        n, v = c.n_robots, self.n_sectors + self.n_doors
        size = 4 * n + 2 * self.n_sectors + 2 * self.n_doors
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float32)
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._others = np.array([[j for j in range(n) if j != i] for i in range(n)], dtype=int).reshape(n, n - 1)
        self._n_places = v
        #: The team's model (eq. 1) and the clutter re-estimate (eq. 2): static graphs over views of the
        #: episode's rows (``_use_rows`` binds them), built once.
        self.model = TopologicalModel(office)
        self.clutter_estimate = ClutterEstimate(self.model.clutter, c.clutter_prior_weight)
        self._pose_rows = PoseRows()
        self._use_rows(ExplorationArrays(n, self.ring.width, c.sensor_range, self.model.clutter, self.model.door_open, 1), 0)
        try:
            self._sample_starts(np.random.default_rng(0))
        except RuntimeError as error:
            raise ConfigError(f"ExplorationConfig: {error}") from None

    # -- construction ----------------------------------------------------------------
    @property
    def map(self) -> OfficeMap:
        """The workspace (the a-priori world model of section 2.1)."""
        return cached_map(self.config.map)

    def _agent_names(self) -> list[str]:
        return [f"robot_{i}" for i in range(self.config.n_robots)]

    def _make_action_type(self) -> ActionType:
        if self.config.action_type == "velocity":
            return VelocityAction(self.spec_robot)
        return OperatorAction(self.operator_set, self.config, self.spec_robot.radius)

    def _make_layout(self) -> ObservationLayout:
        """The fields of the module docstring; the map's walls keep robots in its workspace."""
        c, n, s, d = self.config, self.config.n_robots, len(self.map.sectors), len(self.map.doors)
        low, high = region(c, self.map.size, walled=True)
        v, omega = speed_limits(c, self.spec_robot)
        return ObservationLayout(
            [
                Field("pose", (3,), [*low, -math.pi], [*high, math.pi]),
                Field("velocity", (2,), [-v, -omega], [v, omega]),
                Field("sector", (s,), 0.0, 1.0),
                Field("place", (s + d,), 0.0, 1.0),
                Field("proximity", (len(KHEPERA_RING),), 0.0, c.sensor_range),
                Field("mates_sector", (n - 1, s), 0.0, 1.0),
                Field("mates_place", (n - 1, s + d), 0.0, 1.0),
                Field("visited", (s,), 0.0, 1.0),
                Field("goal", (s,), 0.0, 1.0),
                Field("door_belief", (d,), 0.0, 1.0),
                Field("clutter", (s,), 0.0, 1.0),
                Field("task_status", (len(WatcherState),), 0.0, 1.0),
                Field("task", (1,), -1.0, len(self.operators) - 1),
            ]
        )

    def _build(self, rng: np.random.Generator) -> None:
        c, office = self.config, self.map
        self.world = World(office.size, **c.world_options())
        self._scene.release()  # out of the last episode's world, so that doors close without a check
        for door_id, is_open in self._sample_doors(rng).items():
            self._apply_door(door_id, is_open)
        self._scene.place(self.world)
        starts, headings = self._sample_starts(rng)
        self.robots = {}
        for agent, start, heading in zip(self.possible_agents, starts, headings):
            self.robots[agent] = self.world.add(DiffDriveRobot(agent, start, heading, self.spec_robot))
        self.robot_list = list(self.robots.values())
        self._arrays.start(self._copy, [self.doors[d].is_open for d in office.door_ids])
        self._arrays.explored_all[self._copy] = not self.goal.any()
        operators = self._operators
        if operators is not None:
            operators.begin(self)
        self.world.read_states()
        self._update_state()
        self._check_goals()
        self._sense()

    # -- per-episode state (this copy's rows of ``self._arrays``) ---------------------------
    def _use_rows(self, team: ExplorationArrays, k: int) -> None:
        """Keep this env's episode state in copy row ``k`` of ``team`` (a batch's; see :class:`ExplorationArrays`).

        The model's clutter and door beliefs and the clutter estimate's sums become views of that row.
        """
        self._arrays, self._copy = team, k
        self.model.clutter, self.model.door_open = team.clutter[k], team.door_belief[k]
        self.clutter_estimate.ratio_sum, self.clutter_estimate.count = team.clutter_sum[k], team.clutter_count[k]

    def _episode_state(self) -> dict[str, Any]:
        """The base's, with this copy's rows of ``_arrays`` in place of the arrays (a batch's hold every copy).

        The model and the clutter estimate are left out: they are fixed objects over views of the rows.
        """
        state = super()._episode_state()
        team, k = state.pop("_arrays"), state.pop("_copy")
        del state["model"], state["clutter_estimate"]
        state["_episode_rows"] = team.row(k)
        return state

    def _adopt_episode_state(self, state: dict[str, Any]) -> None:
        rows = state.pop("_episode_rows", None)
        if rows is None:  # a snapshot of a release that kept the episode in attributes
            rows = _rows_of_attributes(self, state)
        super()._adopt_episode_state(state)
        self._arrays.set_row(self._copy, rows)

    @property
    def _operators(self) -> OperatorAction | None:
        """The operator action type (inside a learned message's wrapper), or ``None`` with velocities."""
        action_type = getattr(self.action_type, "motion", self.action_type)
        return action_type if isinstance(action_type, OperatorAction) else None

    @property
    def visited(self) -> np.ndarray:
        """M_V: the explored sectors (a view of this copy's row)."""
        return self._arrays.visited[self._copy]

    @property
    def _sector(self) -> np.ndarray:
        """Each robot's sector index (a view of this copy's row)."""
        return self._arrays.sector[self._copy]

    @property
    def _place(self) -> np.ndarray:
        """Each robot's place x_i, a vertex index (a view of this copy's row)."""
        return self._arrays.place[self._copy]

    @property
    def _watchers(self) -> list:
        """Each robot row's task watcher (owned by the operator action type; empty with velocities)."""
        operators = self._operators
        return [] if operators is None else operators.watchers

    def _poses(self) -> list[tuple[float, float, float]]:
        """``(x, y, θ)`` of every robot row as floats (converted once per state read)."""
        return self._pose_rows(self.world.robot_states)

    def _sample_doors(self, rng: np.random.Generator) -> dict[str, bool]:
        """Door states for an episode: o_j draws unless ``door_states="open"`` or forced by the config."""
        c = self.config
        draws = rng.random(self.n_doors)
        states = {}
        for door, u in zip(self.map.doors, draws.tolist()):
            if door.id in c.closed_doors:
                states[door.id] = False
            elif door.id in c.open_doors or c.door_states == "open":
                states[door.id] = True
            else:
                states[door.id] = u < door.open_probability
        return states

    def _sample_starts(self, rng: np.random.Generator) -> tuple[list[tuple[float, float]], np.ndarray]:
        """Start positions (in ``start_sectors`` or distinct random sectors) and headings."""
        c, office = self.config, self.map
        n, r = c.n_robots, self.spec_robot.radius if hasattr(self, "spec_robot") else RobotSpec.radius
        ids = office.sector_ids
        names = list(c.start_sectors) or [ids[k] for k in rng.choice(len(ids), size=n, replace=n > len(ids))]
        margin = r + office.wall_thickness / 2 + 0.01
        starts: list[tuple[float, float]] = []
        for name in names:
            p = self._place_in(office.sector(name), starts, r, margin, rng)
            if p is None and not c.start_sectors:  # a sector full of robots (more robots than sectors): try the others
                p = next(
                    (
                        q
                        for k in rng.permutation(len(ids))
                        if (q := self._place_in(office.sector(ids[k]), starts, r, margin, rng))
                    ),
                    None,
                )
            if p is None:
                raise ConfigError(
                    f"ExplorationConfig: n_robots={n} robots do not fit clear of furniture, doors and each other "
                    f"(sector {name!r} is full{'' if c.start_sectors else ', and so is every other'}); use fewer robots"
                )
            starts.append(p)
        return starts, rng.uniform(-np.pi, np.pi, size=n)

    def _place_in(self, s, starts: list, r: float, margin: float, rng: np.random.Generator) -> tuple[float, float] | None:
        """A free start in sector ``s`` (its centre if ``start_positions="centre"`` and free), or None after 2,000 tries."""
        if self.config.start_positions == "centre" and self._free(s.centre, starts, r):
            return s.centre
        for _ in range(2000):
            p = (float(rng.uniform(s.x_min + margin, s.x_max - margin)), float(rng.uniform(s.y_min + margin, s.y_max - margin)))
            if self._free(p, starts, r):
                return p
        return None

    def _free(self, p: tuple[float, float], others: list[tuple[float, float]], r: float) -> bool:
        office = self.map
        if any(math.dist(p, q) < 2 * r + 0.02 for q in others):
            return False
        if any(math.dist(p, d.centre) < d.radius + r for d in office.doors):
            return False
        reach = r + 0.01
        x, y = p
        for f, (x0, y0, x1, y1) in zip(office.furniture, self._furniture_boxes):
            # Far outside the bounding box (by more than rounding could blur) is clear without measuring.
            if x0 - x > reach + 1e-9 or x - x1 > reach + 1e-9 or y0 - y > reach + 1e-9 or y - y1 > reach + 1e-9:
                continue
            if not distance_to_polygon(f.vertices, p) > reach:
                return False
        return True

    # -- run-time events ---------------------------------------------------------------
    def set_door(self, door_id: str, is_open: bool) -> bool:
        """Open or close door ``door_id`` now (recorded for copies); False if a body blocks closing."""
        if self.world is None:
            raise EpisodeOverError("set_door() called before reset()")
        if door_id not in self.doors:
            raise KeyError(f"unknown door {door_id!r}; map {self.map.name!r} has {self.map.door_ids}")
        if not isinstance(is_open, (bool, np.bool_)):
            raise TypeError(f"is_open must be True or False, got {is_open!r}")
        done = self._apply_door(door_id, bool(is_open))
        self._record("set_door", door_id, bool(is_open))
        return done

    def _apply_door(self, door_id: str, is_open: bool) -> bool:
        """Open or close the door entity; ``door_is_open`` follows its state (a close may be refused)."""
        door = self.doors[door_id]
        if is_open:
            door.open()
            done = True
        else:
            done = door.close()
        self._arrays.door_is_open[self._copy, self._door_row[door_id]] = door.is_open
        return done

    def _before_physics(self) -> None:
        c = self.config
        period = int(round(c.door_resample_period / c.dt))
        if period > 0 and self.cycles > 0 and self.cycles % period == 0:
            for door_id, is_open in self._sample_doors(self.np_random).items():
                self._apply_door(door_id, is_open)

    def _update_state(self) -> None:
        """After a control step: sectors, places, door sightings, the explored set and contacts.

        A robot is in the first sector whose rectangle, shrunk by 1 mm, holds its centre (else it
        keeps its sector); it sees the doors whose disc holds its centre (their belief becomes
        their state) and is at the nearest of those it believes open, else at its sector.
        Distances are ``sqrt(dx² + dy²)``, as ``np.linalg.norm`` computes them. A batch's copies
        do the same in one pass (:meth:`ExplorationArrays.update_places`).
        """
        state, k = self._arrays, self._copy
        poses = self._poses()
        row = state.sector[k]
        sectors, bounds = row.tolist(), self._sector_bounds
        for i, (x, y, _) in enumerate(poses):
            left, right, bottom, top = bounds[sectors[i]]
            if self._sectors_disjoint and left < x < right and bottom < y < top:
                continue  # still in its sector, which no other sector overlaps
            for s, (x0, x1, y0, y1) in enumerate(bounds):
                if x > x0 and x < x1 and y > y0 and y < y1:
                    sectors[i] = s
                    break
        row[:] = sectors
        places = sectors
        if self.n_doors:
            near = [self._doors_near(x, y) for x, y, _ in poses]
            beliefs, truth = state.door_belief[k], state.door_is_open[k]
            for j in sorted({j for seen in near for j, _ in seen}):
                beliefs[j] = 1.0 if truth[j] else 0.0
            places = list(sectors)
            for i, seen in enumerate(near):
                best, door = math.inf, -1
                for j, d in seen:
                    if d < best and beliefs[j] > 0:
                        best, door = d, j
                if door >= 0:
                    places[i] = self.n_sectors + door
        state.place[k] = places
        visited = state.visited[k]
        fresh = [p for p in sorted(set(places)) if p < self.n_sectors and not visited[p]]  # newly explored sectors
        if fresh:
            visited[fresh] = True
            state.explored_all[k] = bool(np.all(visited[self.goal]))
        if fresh:
            newly = sum(self._goal_list[p] for p in fresh)
            state.newly_explored[k] = newly
            state.explored_goals[k] += newly
        else:
            state.newly_explored[k] = 0
        self._count_contacts()

    def _count_contacts(self) -> None:
        """This control step's contacts per robot (``hits``), their running counts and ``collided``."""
        state, k = self._arrays, self._copy
        if self.world.contacts:
            hits = self.world.contacts_per(self.possible_agents)
            state.hits[k] = hits
            state.collisions[k] += hits
            state.collided[k] = hits > 0
            state.any_hits[k] = True
        elif state.any_hits.item(k):  # no contact this step: every count 0
            state.hits[k] = 0
            state.collided[k] = False
            state.any_hits[k] = False

    def _doors_near(self, x: float, y: float) -> list[tuple[int, float]]:
        """``(door index, distance)`` of the doors whose disc holds ``(x, y)``, in door order.

        A door with ``|dx| >= r`` or ``|dy| >= r`` is skipped unmeasured: its distance is at least
        that (a rounded square's root gives back ``|dx|``, and adding ``dy²`` cannot lower it).
        """
        near = []
        for j, (cx, cy, r) in enumerate(self._door_discs):
            dx, dy = x - cx, y - cy
            if -r < dx < r and -r < dy < r:
                d = math.sqrt(dx * dx + dy * dy)
                if d < r:
                    near.append((j, d))
        return near

    def _check_goals(self) -> None:
        state, k = self._arrays, self._copy
        if state.newly_explored.item(k) and state.explored_all.item(k) and math.isnan(state.explore_time.item(k)):
            state.explore_time[k] = self.cycles * self.config.dt

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        """``explore_reward`` per newly explored goal sector − ``time_penalty``, shared; − ``collision_penalty`` per contact."""
        c, state, k = self.config, self._arrays, self._copy
        total += c.explore_reward * state.newly_explored.item(k) - c.time_penalty
        self._contact_penalties(total)

    def _contact_penalties(self, total: np.ndarray) -> None:
        """``collision_penalty`` off ``total[i]`` once per contact of robot ``i`` this control step (a running sum)."""
        state, k = self._arrays, self._copy
        if not state.any_hits.item(k):
            return
        penalty, hits = self.config.collision_penalty, state.hits[k]
        for i in np.flatnonzero(hits).tolist():
            for _ in range(int(hits[i])):
                total[i] -= penalty

    def _sense(self) -> None:
        """Proximity rings of every robot (the behaviour-based controller reads them)."""
        out = self._arrays.proximity[self._copy]
        self.ring.read_rows(self.world, self.robot_list, self.world.robot_states, self.np_random, out)

    def _all_explored(self) -> bool:
        """Every goal sector explored (kept up to date by :meth:`_update_state`)."""
        return self._arrays.explored_all.item(self._copy)

    def _terminations(self) -> dict[str, bool]:
        return dict.fromkeys(self.live_agents, self._all_explored())

    # -- observations, metrics -------------------------------------------------------
    def _observe(self, out: np.ndarray) -> None:
        """Rows of the live agents (module docstring); fields every robot observes alike written once for all rows."""
        at = self.__dict__.get("_field_starts")
        if at is None:
            names = ("velocity", "sector", "place", "mates_sector", "mates_place", "task_status", "task")
            at = self._field_starts = {name: self.layout.slices[name].start for name in names}
        s, v = self.n_sectors, self.n_sectors + self.n_doors
        team, k = self._arrays, self._copy
        sectors, places = team.sector[k].tolist(), team.place[k].tolist()
        index, states, others = self._index, self.world.robot_states, self._others
        for row, agent in enumerate(self.live_agents):
            i = index[agent]
            buffer = out[row]
            x, y, theta, vx, vy, omega = states[i].tolist()
            buffer[0:3] = (x, y, math.remainder(theta, 2 * math.pi))
            buffer[at["velocity"] : at["velocity"] + 2] = (vx * math.cos(theta) + vy * math.sin(theta), omega)
            buffer[at["sector"] + sectors[i]] = 1.0
            buffer[at["place"] + places[i]] = 1.0
            for row_m, j in enumerate(others[i].tolist()):
                buffer[at["mates_sector"] + row_m * s + sectors[j]] = 1.0
                buffer[at["mates_place"] + row_m * v + places[j]] = 1.0
        fields, rows = self.layout.slices, self._live_rows()
        out[:, fields["proximity"]] = team.proximity[k] if len(rows) == len(sectors) else team.proximity[k, rows]
        for name, value in self._shared_fields():
            out[:, fields[name]] = value
        operators = self._operators if self.action_type.is_macro else None
        if operators is None:
            out[:, at["task_status"] + int(WatcherState.WAITING)] = 1.0
            out[:, at["task"]] = -1.0
            return
        status, tasks = operators.task_rows()
        for row, i in enumerate(rows.tolist()):
            out[row, at["task_status"] + status[i]] = 1.0
            out[row, at["task"]] = tasks[i]

    def _task_rows(self) -> tuple[list[int], list[int]]:
        """Per robot row: watcher state and current operator (−1); waiting and none without operators."""
        operators = self._operators
        if operators is None:
            n = len(self.possible_agents)
            return [int(WatcherState.WAITING)] * n, [-1] * n
        return operators.task_rows()

    def _shared_fields(self) -> list[tuple[str, np.ndarray]]:
        """The fields every robot observes alike: explored sectors, goals, door beliefs, clutter."""
        return [
            ("visited", self._arrays.visited[self._copy]),
            ("goal", self.goal),
            ("door_belief", self.model.door_open),
            ("clutter", self.model.clutter),
        ]

    def _info_keys(self) -> dict[str, InfoKey]:
        """Counts from reset on, ``explore_time`` (s) NaN until every goal sector is explored; ``sector``, ``place``
        and (operators) ``task``, ``task_status``, ``task_reason`` are categorical (``decode_info`` names them)."""
        keys = {
            **metrics("explored", "explored_fraction", "explored_all", "path_length", "team_path_length", "collisions"),
            **categorical("sector", "place"),
            **unknown("explore_time"),
        }
        if self.action_type.is_macro:
            keys.update(metrics("stages", "tasks_completed", "tasks_failed"))
            keys.update(categorical("task", "task_status", "task_reason"))
        return keys

    def _metrics(self, agent: str) -> dict[str, Any]:
        return self._metrics_of([agent])[agent]

    def _metrics_of(self, agents: list[str]) -> dict[str, dict[str, Any]]:
        """Per-robot metrics; the team-wide ones (explored set, team path, explore time) computed once."""
        state, k = self._arrays, self._copy
        explored = state.explored_goals.item(k)  # np.count_nonzero(self.visited & self.goal), kept by _update_state
        team: dict[str, Any] = {
            "explored": explored,
            "explored_fraction": explored / self._n_goals,
            "explored_all": state.explored_all.item(k),
        }
        team_path = float(sum(r.odometer for r in self.robot_list))
        collisions, sectors, places = state.collisions[k].tolist(), state.sector[k].tolist(), state.place[k].tolist()
        operators = self._operators if self.action_type.is_macro else None  # task bookkeeping: operators only
        explore_time = state.explore_time.item(k)
        out = {}
        for agent in agents:
            i = self._index[agent]
            metrics = {
                **team,
                "path_length": float(self.robot_list[i].odometer),
                "team_path_length": team_path,
                "collisions": collisions[i],
                "sector": sectors[i],
                "place": places[i],
            }
            if not math.isnan(explore_time):
                metrics["explore_time"] = explore_time
            if operators is not None:
                metrics.update(
                    stages=int(state.stages[k]),
                    tasks_completed=int(state.completed[k, i]),
                    tasks_failed=int(state.failed[k, i]),
                    **operators.task_metrics(i),
                )
            out[agent] = metrics
        return out

    def decode_info(self, info: dict[str, Any]) -> dict[str, Any]:
        """``info`` with its indices named: ``sector``/``place`` as map ids, ``task`` as the operator,
        ``task_status`` as the watcher state, ``task_reason`` as the reason (infos hold numbers only)."""
        named = dict(info)
        office = self.map
        if "sector" in info:
            named["sector"] = office.sector_ids[int(info["sector"])]
        if "place" in info:
            named["place"] = office.vertex_ids[int(info["place"])]
        if "task" in info:
            named["task"] = self.operators[int(info["task"])].name if int(info["task"]) >= 0 else ""
        if "task_status" in info:
            named["task_status"] = WATCHER_STATES[int(info["task_status"])]
        if "task_reason" in info:
            named["task_reason"] = TASK_REASONS[int(info["task_reason"])]
        return named

    def episode_success(self) -> bool:
        """Every goal sector explored (M_G ⊆ M_V)."""
        return self.world is not None and self._all_explored()

    def state(self) -> np.ndarray:
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        states = self.world.robot_states
        team, k = self._arrays, self._copy
        robots = np.column_stack([states[:, :3], team.place[k]]).ravel()
        doors = np.array([self.doors[d].is_open for d in self.map.door_ids], dtype=float)
        parts = [robots, team.visited[k].astype(float), team.clutter[k], doors, team.door_belief[k]]
        return np.concatenate(parts).astype(np.float32)

    def _overlay(self) -> Overlay:
        return Overlay(
            points=[(s.centre, (190, 60, 60)) for s, seen, g in zip(self.map.sectors, self.visited, self.goal) if g and not seen]
        )


def _rows_of_attributes(env: Exploration, state: dict[str, Any]) -> dict[str, np.ndarray]:
    """The episode rows of a snapshot that earlier releases wrote (the state in ``_*`` attributes); ``state`` loses them.

    Their watchers and task factory move to the operator action type, as this release keeps them.
    """
    old = {key: state.pop(key) for key in [*state] if key.startswith("_") and key not in env.__dict__}
    visited, model, estimate = state.pop("visited"), state.pop("model"), state.pop("clutter_estimate")
    rows = env._arrays.row(env._copy)
    for name in ("sector", "place", "collisions", "collided", "hits", "completed", "failed", "task_sector", "proximity"):
        rows[name][...] = old[f"_{name}"]
    rows["in_stage"][old.get("_stage_robots", [])] = True
    rows["visited"][:], rows["clutter"][:], rows["door_belief"][:] = visited, model.clutter, model.door_open
    rows["clutter_sum"][:], rows["clutter_count"][:] = estimate.ratio_sum, estimate.count
    rows["door_is_open"][:] = [state["doors"][d].is_open for d in env.map.door_ids]
    for name in ("explored_all", "explored_goals", "newly_explored", "any_hits", "explore_time", "stages"):
        rows[name] = old[f"_{name}"]
    rows["stage_start"], rows["stage_ended"] = old.get("_stage_start", 0), old.get("_stage_ended", False)
    action_type = getattr(state.get("action_type"), "motion", state.get("action_type"))
    if isinstance(action_type, OperatorAction):
        action_type.config, action_type.robot_radius = env.config, env.spec_robot.radius
        action_type.watchers, action_type.tasks = old["_watchers"], old["_tasks"]
    return rows


def parallel_env(render_mode: str | None = None, **config: Any) -> Exploration:
    """The PettingZoo parallel env (same as ``teamgym.make("Exploration-v0", ...)``)."""
    return Exploration(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any):
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
