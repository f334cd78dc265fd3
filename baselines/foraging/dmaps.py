"""DMAPS, the Distributed Multi-Agent Planning System of paper 002, for ``Foraging-v0``.

Every robot runs the same planner on its own data (Fig. 1): perception and the received
packets update its :class:`~teamgym.envs.foraging.world_model.GridWorldModel` (sections
2.2–2.3, 3.2), behaviour selection picks *approach* or *search* (section 4.3), and a MAPS
potential field (:mod:`baselines.foraging.potential`) gives the go-to cell, the action of
``goto_cell``. Per robot and control step:

1. **World model.** Every received packet (with ``communication=False`` the ``received*``
   fields are ignored: ``dmaps-nocomm``), then the robot's own tuples and viewing sector at its
   *estimated* pose, minus the cells hidden behind the robots it sees (occlusion: they keep
   their memory instead of being "seen empty"). The fused map is self-biased (section 3.2).
2. **Known targets**: local maxima of the fused target layer above
   ``target_threshold / n_contributors`` (:meth:`GridWorldModel.known`); peaks within
   ``target_separation`` (2) cells are one target (two robots' localisation errors put their
   reports of one target up to two cells apart; targets are placed 2 reach radii apart).
3. **Team**: the robot itself and its teammates at their latest reported cells (``SENDER``
   tuples younger than ``teammate_timeout``), all at cell centres — every robot then computes
   the allocation from the same quantised positions, ties going to the lower agent index;
   robots the model holds (fused robot-layer peaks, e.g. teammates seen by the camera) fill the
   places of teammates with no fresh report, up to ``n_robots − 1`` others.
4. **Allocation** (section 4.1, :mod:`baselines.foraging.allocation`): ``consume`` pairs robots
   and targets by the shortest-distance method; ``surround`` sends ``robots_per_target``
   robots (the group with the smallest total distance) to a target.
5. **Behaviour** (section 4.3): with an assigned target the robot *approaches* it (go-to cell:
   the target's cell, the peak of the approach field); otherwise it *searches* (go-to cell:
   the fittest cell of the search field: novelty, distance, turning, teammate repulsion). A
   search goal is kept for at least ``min_hold`` s and then until it has been seen, reached,
   ``max_hold`` s have passed or it stops being admissible (hysteresis: no dithering).
6. **At a target** (``at_target`` = 1) the robot *holds* — its go-to cell stays on that target
   (the env's controller stops a robot at a target whose cell is within one cell of its go-to
   cell) — unless the allocation gives that target to other robots and not to it (a robot
   passing by a target a teammate is consuming drives on). The allocation is re-checked every
   ``hold_check`` s while holding. After a consumption (``consume``: progress had reached 1)
   the target is cleared from every partial model; a teammate's consumption is inferred from
   its reports (it stayed put for ``consume_time``) and cleared the same way.
7. **Consumed targets that persist** (``consumed_targets="persist"``: a consumed target stays
   in every camera, looking like a live one). The robot remembers the cells of the targets it
   knows are consumed — its own operation done (``consume_progress`` reached 1 while at a
   target) and a teammate's inferred from its location tuples as in 6 (the paper's packet
   carries no "consumed" tuple: "the location tuple of the transmitting robot and targets and
   obstacles perceived", section 4.3) — and drops the target tuples, its own and received,
   within ``consumed_radius`` cells of them; at such a target it does not hold. Without the
   radio a robot learns of a teammate's consumption only by going there and consuming it
   again ("two robots can redundantly approach and consume the same target", section 5.1).
   In ``vanish`` nothing is remembered (the world says it: the target is gone).

Only ``goto_cell`` is supported (``required_config``). The policy is deterministic.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from baselines.foraging.allocation import greedy_pairs, surround_groups
from baselines.foraging.potential import FieldParams, PotentialField
from baselines.policy import Policy
from teamgym.envs.foraging.world_model import (
    ROBOT,
    ROBOT_LAYER,
    SENDER,
    TARGET,
    TARGET_LAYER,
    GridWorldModel,
    ViewSector,
    WorldModelParams,
)

__all__ = ["DMAPS", "DMAPSParams", "OBSERVATION_FIELDS", "RobotPlanner", "check_goto_cell"]

#: The observation fields DMAPS reads.
OBSERVATION_FIELDS = (
    "pose_estimate",
    "detections",
    "detection_mask",
    "detection_polar",
    "received",
    "received_sender",
    "received_mask",
    "at_target",
    "consume_progress",
)


def check_goto_cell(env: Any, name: str) -> None:
    """Raise ``ValueError`` unless ``env`` uses the ``goto_cell`` action type."""
    action_type = getattr(getattr(env, "config", None), "action_type", None)
    if action_type != "goto_cell":
        raise ValueError(
            f"policy {name!r} outputs go-to cells: it needs Foraging-v0 with action_type='goto_cell', "
            f"got action_type={action_type!r}"
        )


@dataclass(frozen=True)
class DMAPSParams:
    """Thresholds and timings of :class:`DMAPS` (see the module docstring)."""

    #: A fused target peak is a known target above this / n_contributors.
    target_threshold: float = 0.2
    #: Target peaks closer than this (cells, Chebyshev) are one target: two robots' reports of
    #: one target, two cells apart from their localisation errors, must not count twice.
    target_separation: int = 2
    #: A fused robot peak is a robot above this / n_contributors.
    robot_threshold: float = 0.2
    #: A teammate's reported cell (SENDER tuple) is used for this long (s).
    teammate_timeout: float = 10.0
    #: A search goal is kept at least this long (s) ...
    min_hold: float = 1.0
    #: ... and at most this long (s) unless seen or reached earlier.
    max_hold: float = 15.0
    #: While holding at a target, the allocation is re-checked this often (s).
    hold_check: float = 1.0
    #: A teammate reported within ``stay_radius`` cells (Chebyshev) of one cell for
    #: ``consume_time − stay_slack`` s has consumed what was there (consume only).
    stay_radius: int = 2
    stay_slack: float = 1.0
    #: Chebyshev radius (cells) around a consumed target's cell cleared from the model.
    consumed_clear_radius: int = 1
    #: Persist: target tuples within this many cells (Chebyshev) of a known consumed target's
    #: cell are that target (dropped); 1, not ``target_separation``: live targets 0.4 m apart
    #: may lie two cells from a consumed one.
    consumed_radius: int = 1
    world: WorldModelParams = field(default_factory=WorldModelParams)
    potential: FieldParams = field(default_factory=FieldParams)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> DMAPSParams:
        """Parameters from JSON-style data: the defaults overridden by ``values``.

        ``values`` maps field names to numbers; ``world`` and ``potential`` are mappings of
        :class:`WorldModelParams` and :class:`FieldParams` fields (overriding their defaults),
        e.g. ``{"min_hold": 0.0, "potential": {"turn_cost": 0.2}}`` (a preset's
        ``bc.expert_kwargs`` ``{"params": {...}}`` for ``dmaps``). ``TypeError`` names an unknown
        key or a value that is not a number; a nested instance is taken as it is.
        """
        return _params_from_mapping(cls, "dmaps", values, {"world": WorldModelParams, "potential": FieldParams})


def _params_from_mapping(kind: type, name: str, values: Any, nested: Mapping[str, type]) -> Any:
    """``kind(**values)`` with every key and number checked (nested mappings as ``nested[key]``)."""
    if isinstance(values, kind):
        return values
    if not isinstance(values, Mapping) or not all(isinstance(key, str) for key in values):
        raise TypeError(f"{name} parameters must map parameter names to values, got {values!r}")
    defaults = {f.name: f for f in fields(kind)}
    unknown = sorted(set(values) - set(defaults))
    if unknown:
        raise TypeError(f"unknown {name} parameter(s) {unknown}; known: {sorted(defaults)}")
    checked: dict[str, Any] = {}
    for key, value in values.items():
        if key in nested:
            checked[key] = _params_from_mapping(nested[key], f"{name} {key}", value, {})
            continue
        default = getattr(kind(), key)
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if not number or (isinstance(default, int) and not isinstance(value, int)):
            expected = "an integer" if isinstance(default, int) else "a number"
            raise TypeError(f"{name} parameter {key!r} must be {expected}, got {value!r}")
        checked[key] = float(value) if isinstance(default, float) else value
    return kind(**checked)


class RobotPlanner:
    """One robot's DMAPS: its world model and behaviour state (``decide`` gives its go-to cell)."""

    def __init__(self, index: int, policy: DMAPS) -> None:
        self.index = index
        self.policy = policy
        c = policy.env.config
        self.model = GridWorldModel(c.grid, c.n_robots, index, policy.params.world)
        self.behaviour = "search"
        self.goal = -1
        self.goal_time = -math.inf
        self.target: tuple[int, int] | None = None
        self.hold_cell: tuple[int, int] | None = None
        self.hold_checked = -math.inf
        self._stays: dict[int, list] = {}  # teammate -> [anchor cell, first time, last time] (consume inference)
        self.consumed_cells: list[tuple[int, int]] = []  # persist: cells of targets known consumed
        self.prev_at = False
        self.prev_progress = 0.0
        self.known_targets = np.zeros((0, 2), dtype=np.int64)
        self.team = np.zeros((0, 2))

    # -- perception -------------------------------------------------------------------
    def perceive(self, fields: dict[str, np.ndarray], now: float) -> None:
        """Update the world model with this step's observation (received packets first, then the own view)."""
        p = self.policy
        if p.communication:
            valid = fields["received_mask"].tolist()
            if any(valid):
                packet: list[list[float]] = []
                sender = -1
                # Packets are contiguous, each starting with its SENDER tuple.
                for row, who, ok in zip(fields["received"].tolist(), fields["received_sender"].tolist(), valid):
                    if not ok:
                        continue
                    if packet and (int(row[0]) == SENDER or who != sender):
                        self.model.receive(sender, self._unconsumed(packet), now)
                        packet = []
                    packet.append(row)
                    sender = who
                if packet:
                    self.model.receive(sender, self._unconsumed(packet), now)
        pose = fields["pose_estimate"].tolist()
        sector = p.sectors.cached(pose[0], pose[1], pose[2])
        own = [row for row, valid in zip(fields["detections"].tolist(), fields["detection_mask"].tolist()) if valid]
        robots = [k for k, row in enumerate(own) if int(row[0]) == ROBOT]
        if robots:  # cells hidden behind the robots in view are not seen (they keep their memory)
            polar = fields["detection_polar"][np.flatnonzero(fields["detection_mask"])[robots]]
            sector &= ~p.sectors.shadow(pose[0], pose[1], pose[2], polar, p.robot_radius)
        self.model.observe_own(self._unconsumed(own), sector, now)

    def _unconsumed(self, rows: list[list[float]]) -> list[list[float]]:
        """``rows`` without the target tuples within ``consumed_radius`` cells of a cell known consumed (persist)."""
        if not self.consumed_cells:
            return rows
        return [row for row in rows if int(row[0]) != TARGET or not self.is_consumed((int(row[1]), int(row[2])))]

    def is_consumed(self, cell: tuple[int, int]) -> bool:
        """Whether ``cell`` is within ``consumed_radius`` cells (Chebyshev) of a target known consumed."""
        reach = self.policy.params.consumed_radius
        return any(abs(cell[0] - gx) <= reach and abs(cell[1] - gy) <= reach for gx, gy in self.consumed_cells)

    def remember_consumed(self, cell: tuple[int, int] | np.ndarray) -> None:
        """Persist only: keep ``cell`` as a consumed target's (its tuples are dropped from then on)."""
        if self.policy.remember_consumed:
            cell = (int(cell[0]), int(cell[1]))
            if cell not in self.consumed_cells:
                self.consumed_cells.append(cell)

    def teammates(self, fused: np.ndarray, now: float) -> tuple[np.ndarray, int]:
        """Positions ``(m, 2)`` of the team ordered by agent index (anonymous robots last) and this robot's row."""
        p, model = self.policy, self.model
        n = model.n_robots
        timeout = now - p.params.teammate_timeout
        sender_time, sender_cell = model.sender_times, model.sender_cells
        rows: list[tuple[float, float]] = []
        taken: list[tuple[int, int, int]] = [(self._cell[0], self._cell[1], 2)]  # cells (and radii) explained
        mine = 0
        for r in range(n):
            if r == self.index:
                mine = len(rows)
                rows.append(p.centre(*self._cell))
            elif sender_time[r] >= timeout and sender_cell[r][0] >= 0:
                gx, gy = sender_cell[r]
                rows.append(p.centre(gx, gy))
                taken.append((gx, gy, 1))
        room = n - len(rows)
        if room > 0:
            cells, _ = model.known(ROBOT_LAYER, p.params.robot_threshold, fused)
            for gx, gy in cells.tolist():
                if room == 0:
                    break
                if all(abs(gx - tx) > rad or abs(gy - ty) > rad for tx, ty, rad in taken):
                    rows.append(p.centre(gx, gy))
                    taken.append((gx, gy, 1))
                    room -= 1
        return np.array(rows, dtype=float).reshape(-1, 2), mine

    # -- decision ---------------------------------------------------------------------
    def decide(self, fields: dict[str, np.ndarray], action_mask: np.ndarray | None, now: float) -> int:
        """The go-to cell (flat index) of this robot for this step."""
        p = self.policy
        grid, params, model = p.grid, p.params, self.model
        self.perceive(fields, now)
        pose = fields["pose_estimate"]
        self._position = (float(pose[0]), float(pose[1]))
        self._cell = p.cell_of(*self._position)
        at = bool(fields["at_target"][0] > 0)
        progress = float(fields["consume_progress"][0])
        if p.search_only:
            team, mine = self.teammates(model.fused_map(self_bias=True), now) if model.n_robots > 1 else (np.zeros((1, 2)), 0)
            return self._search(fields, team, mine, action_mask, now)
        if p.remember_consumed:  # persist: the operation here is done (once per stay); the target stays
            consumed = at and progress >= 1.0 - 1e-6 > self.prev_progress
        else:  # vanish: it is gone (the robot was at it, almost done, and is no longer at a target)
            consumed = self.prev_at and not at and self.prev_progress >= 1.0 - 1.5 * p.dt / p.consume_time
        if consumed and self.hold_cell is not None and p.task == "consume":
            model.clear(self.hold_cell, params.consumed_clear_radius)
            self.remember_consumed(self.hold_cell)
        self.prev_at, self.prev_progress = at, progress
        if p.remember_consumed and at and (progress >= 1.0 - 1e-6 or self.is_consumed(self._target_here(fields, self._cell)[1])):
            at, self.hold_cell = False, None  # persist: done here, or at a target known consumed: drive on
        if p.communication and p.task == "consume":
            self._teammate_stays(now)
        if at and self.hold_cell is not None and now - self.hold_checked < params.hold_check - 1e-9:
            return self._set_goal("hold", self.hold_cell[1] * grid.nx + self.hold_cell[0], now, action_mask)

        fused = model.fused_map(self_bias=True)
        self.known_targets, _ = model.known(TARGET_LAYER, params.target_threshold, fused, params.target_separation)
        team, mine = self.teammates(fused, now)
        self.team = team
        allocation = np.zeros(0, dtype=np.int64)
        if len(self.known_targets):
            targets = [p.centre(gx, gy) for gx, gy in self.known_targets.tolist()]
            if p.task == "surround":
                allocation = surround_groups(team, targets, p.robots_per_target)
            else:
                allocation = greedy_pairs(team, targets)
        assigned = int(allocation[mine]) if len(allocation) else -1
        if at:
            here, cell = self._target_here(fields, self.hold_cell or self._cell)
            # Hold unless the target here is allocated to other robots and not to this one.
            if here < 0 or assigned == here or not np.any(allocation == here):
                self.hold_cell, self.hold_checked = cell, now
                return self._set_goal("hold", cell[1] * grid.nx + cell[0], now, action_mask)
        self.hold_cell = None
        if assigned >= 0:
            cell = self.known_targets[assigned]
            self.target = (int(cell[0]), int(cell[1]))
            flat = self.target[1] * grid.nx + self.target[0]
            if action_mask is not None and not action_mask[flat]:
                flat = p.field.best(p.field.approach(cell), action_mask)
            return self._set_goal("approach", flat, now, action_mask)
        self.target = None
        return self._search(fields, team, mine, action_mask, now)

    def _search(self, fields, team, mine, action_mask, now) -> int:
        p, params = self.policy, self.policy.params
        if self.behaviour == "search" and self.goal >= 0 and not (self.consumed_cells and self.is_consumed(self._goal_cell())):
            elapsed = now - self.goal_time
            gx, gy = self.goal % p.grid.nx, self.goal // p.grid.nx
            admissible = action_mask is None or bool(action_mask[self.goal])
            seen = self.model.last_seen[gy, gx] > self.goal_time
            reached = gx == self._cell[0] and gy == self._cell[1]
            if admissible and (elapsed < params.min_hold - 1e-9 or not (seen or reached or elapsed >= params.max_hold - 1e-9)):
                return self.goal
        others = np.delete(team, mine, axis=0)
        fitness = p.field.search(now, self.model.last_seen, fields["pose_estimate"], others)
        mask = action_mask
        if self.consumed_cells:  # persist: no search goal that homes the robot onto a consumed target
            mask = self._away_from_consumed(action_mask)
        return self._set_goal("search", p.field.best(fitness, mask), now, action_mask, force=True)

    def _away_from_consumed(self, action_mask: np.ndarray | None) -> np.ndarray | None:
        """``action_mask`` minus the cells within ``consumed_radius + 1`` of a consumed target (as given if none is left).

        The env's controller homes on a target seen within one cell of the go-to cell, and a
        consumed target's reports scatter by a cell around the remembered one.
        """
        grid, reach = self.policy.grid, self.policy.params.consumed_radius + 1
        near = np.zeros((grid.ny, grid.nx), dtype=bool)
        for gx, gy in self.consumed_cells:
            near[max(0, gy - reach) : gy + reach + 1, max(0, gx - reach) : gx + reach + 1] = True
        allowed = ~near.ravel() if action_mask is None else (np.asarray(action_mask).ravel() > 0) & ~near.ravel()
        return allowed if allowed.any() else action_mask

    def _goal_cell(self) -> tuple[int, int]:
        return self.goal % self.policy.grid.nx, self.goal // self.policy.grid.nx

    def _set_goal(self, behaviour: str, flat: int, now: float, action_mask, force: bool = False) -> int:
        flat = int(flat)
        if action_mask is not None and not action_mask[flat]:
            flat = self.policy.field.best(self.policy.field.approach(self.policy.grid.cell_at(flat)), action_mask)
        if force or behaviour != self.behaviour or flat != self.goal:
            self.goal_time = now
        self.behaviour, self.goal = behaviour, flat
        return flat

    def _teammate_stays(self, now: float) -> None:
        """Infer consumptions by teammates from their reported cells (``consume`` only).

        A robot that stays within reach of a target for ``consume_time`` consumes it, so when a
        teammate whose reports stayed within ``stay_radius`` cells of an anchor cell (the reported
        cell jitters as a holding robot turns a little) for at least ``consume_time − stay_slack``
        s moves on, the targets there are gone: the target layer is cleared within
        ``consumed_clear_radius`` of the anchor and of the nearest known target within 2 cells
        of it, in every partial model. Packets lost on the way only shorten the observed stay
        (no false clearing from gaps).
        """
        model, params, p = self.model, self.policy.params, self.policy
        times, cells = model.sender_times, model.sender_cells
        for r, (time, cell) in enumerate(zip(times, cells)):
            if r == self.index or time < now or cell[0] < 0:
                continue
            stay = self._stays.get(r)
            near_anchor = stay is not None and max(abs(cell[0] - stay[0][0]), abs(cell[1] - stay[0][1])) <= params.stay_radius
            if near_anchor:
                stay[2] = now
                continue
            if stay is not None and stay[2] - stay[1] >= p.consume_time - params.stay_slack:
                anchor = stay[0]
                known, _ = model.known(TARGET_LAYER, params.target_threshold, separation=params.target_separation)
                near = [(abs(tx - anchor[0]) + abs(ty - anchor[1]), tx, ty) for tx, ty in known.tolist()]
                near = [n for n in near if abs(n[1] - anchor[0]) <= 2 and abs(n[2] - anchor[1]) <= 2]
                model.clear(anchor, params.consumed_clear_radius)
                if near:
                    model.clear(min(near)[1:], params.consumed_clear_radius)
                    _, tx, ty = min(near)
                    if max(abs(tx - anchor[0]), abs(ty - anchor[1])) <= params.consumed_radius:
                        self.remember_consumed((tx, ty))  # persist: only a known target the teammate stood at
            self._stays[r] = [tuple(cell), now, now]

    def _target_here(self, fields: dict[str, np.ndarray], default: tuple[int, int]) -> tuple[int, tuple[int, int]]:
        """The target the robot is at: (index in ``known_targets`` or −1, its cell).

        The nearest known target within 2 cells; else (not known) the nearest target the
        robot sees within 2 cells; else ``default`` (the cell it holds at already, or its own).
        """
        gx, gy = self._cell
        x, y = self._position
        centre = self.policy.centre
        best, best_distance = -1, math.inf
        for j, (tx, ty) in enumerate(self.known_targets.tolist()):
            if abs(tx - gx) <= 2 and abs(ty - gy) <= 2:
                cx, cy = centre(tx, ty)
                if math.hypot(cx - x, cy - y) < best_distance:
                    best, best_distance = j, math.hypot(cx - x, cy - y)
        if best >= 0:
            tx, ty = self.known_targets[best].tolist()
            return best, (tx, ty)
        cell = default
        for row, valid in zip(fields["detections"].tolist(), fields["detection_mask"].tolist()):
            if valid and int(row[0]) == TARGET:
                tx, ty = int(row[1]), int(row[2])
                if abs(tx - gx) <= 2 and abs(ty - gy) <= 2:
                    cx, cy = centre(tx, ty)
                    if math.hypot(cx - x, cy - y) < best_distance:
                        cell, best_distance = (tx, ty), math.hypot(cx - x, cy - y)
        return -1, cell


class DMAPS(Policy):
    """Distributed Multi-Agent Planning System (paper 002); see the module docstring.

    ``communication=False`` ignores every received packet (``dmaps-nocomm``): each robot
    plans on its own perception only. ``params`` overrides :class:`DMAPSParams`: an instance,
    or a mapping of its fields (JSON data, e.g. ``{"min_hold": 0.0}``;
    :meth:`DMAPSParams.from_mapping`), which a preset's ``bc.expert_kwargs`` can pass.
    ``search_only=True`` runs the search behaviour alone (no approach, no hold: targets are
    modelled but ignored), e.g. to time how long a robot takes to cover the field.
    """

    name = "dmaps"
    env_ids = ("Foraging-v0",)
    observation_fields = OBSERVATION_FIELDS
    required_config = {"action_type": "goto_cell"}

    def __init__(
        self,
        env: Any,
        communication: bool = True,
        params: DMAPSParams | Mapping[str, Any] | None = None,
        search_only: bool = False,
    ) -> None:
        super().__init__(env)
        check_goto_cell(env, "dmaps" if communication else "dmaps-nocomm")
        if params is not None and not isinstance(params, DMAPSParams):
            params = DMAPSParams.from_mapping(params)
        c = env.config
        self.communication = bool(communication)
        self.search_only = bool(search_only)
        self.params = params or DMAPSParams()
        self.grid = c.grid
        self.task = c.task
        self.dt = float(c.dt)
        self.consume_time = float(c.consume_time)
        self.robots_per_target = int(c.robots_per_target)
        #: Remember consumed targets' cells (``consumed_targets="persist"``: they stay in the cameras).
        self.remember_consumed = getattr(c, "consumed_targets", "vanish") == "persist"
        #: The robots' own radius (m), for the shadows they cast in the camera's view.
        self.robot_radius = float(getattr(c, "robot_radius", 0.09))
        self.sectors = ViewSector(self.grid, c.camera_range, c.camera_fov)
        self._nx, self._ny, self._cell_size = self.grid.nx, self.grid.ny, self.grid.cell_size
        self._centres = self.grid.centres().tolist()
        layout = env.layout
        shapes = {name: layout.shapes[name] if len(layout.shapes[name]) > 1 else None for name in OBSERVATION_FIELDS}
        self._slices = [(name, layout.slices[name], shapes[name]) for name in OBSERVATION_FIELDS]  # None: a 1-D field
        self.field = PotentialField(self.grid, self.params.potential)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.planners = {agent: RobotPlanner(i, self) for i, agent in enumerate(self.env.possible_agents)}
        self.steps = 0

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The grid cell ``(gx, gy)`` of a point (as :meth:`GridSpec.cell_of`, in plain Python)."""
        gx = min(self._nx - 1, max(0, math.floor(x / self._cell_size + 1e-9)))
        gy = min(self._ny - 1, max(0, math.floor(y / self._cell_size + 1e-9)))
        return gx, gy

    def centre(self, gx: int, gy: int) -> tuple[float, float]:
        """Centre (m) of cell ``(gx, gy)`` (as :meth:`GridSpec.centre_of`)."""
        return tuple(self._centres[gy][gx])

    @property
    def time(self) -> float:
        """Seconds since the episode's first observation (one ``dt`` per ``act`` call)."""
        return self.steps * self.dt

    def fields(self, observation: Any) -> dict[str, np.ndarray]:
        """The observation fields DMAPS reads (views of a flat observation; a dict one as given)."""
        if isinstance(observation, np.ndarray) and observation.ndim == 1:
            return {name: observation[s] if shape is None else observation[s].reshape(shape) for name, s, shape in self._slices}
        return self.env.decode(observation)

    def act(self, observations: dict[str, Any], infos: dict[str, dict] | None = None) -> dict[str, int]:
        now = self.time
        actions = {}
        for agent, obs in observations.items():
            mask = (infos or {}).get(agent, {}).get("action_mask")
            actions[agent] = self.planners[agent].decide(self.fields(obs), None if mask is None else np.asarray(mask), now)
        self.steps += 1
        return actions

    def plans(self) -> dict[str, dict[str, Any]]:
        """Every robot's current behaviour, go-to cell, assigned target cell and known target cells."""
        out = {}
        for agent, planner in self.planners.items():
            out[agent] = {
                "behaviour": planner.behaviour,
                "goal": planner.goal,
                "target": planner.target,
                "hold": planner.hold_cell,
                "known_targets": [tuple(int(v) for v in cell) for cell in planner.known_targets],
            }
        return out
