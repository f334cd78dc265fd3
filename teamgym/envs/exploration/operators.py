"""The operators of paper 000 (sections 2.2 and 3.1) as the macro action type of ``Exploration-v0``.

Every map gets a fixed list of operators: index 0 is Wait(), then FindDoor(D) for every
door, TraverseDoor(D, S) for every door and each of its two sectors, and GoTo(S1, S2) for
every ordered pair of sectors joined by an open passage. Preconditions (section 3.1), with
x_i the robot's place (a sector, or a door object while the robot is inside its circle):

* FindDoor(D):        x_i ∈ V_S, w(x_i, D) ≠ ∞
* TraverseDoor(D, S): x_i = D,   w(D, S) ≠ ∞
* GoTo(S1, S2):       x_i = S1,  w(S1, S2) ≠ ∞
* Wait():             none

Effects (eq. 6): x_i^{n+1} = D, S, S2 and x_i respectively. Each operator becomes a
:class:`~teamgym.control.watcher.Task` for the behaviour-based controller: waypoints, a
completion test, the behaviour priorities and the velocity limit (section 2.2).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import TYPE_CHECKING, Protocol

import numpy as np

from teamgym.control.behaviour import DEFAULT_PRIORITIES, NARROW_PASSAGE, BehaviourParameters
from teamgym.control.watcher import TASK_REASONS, Task, TaskWatcher, WatcherState
from teamgym.envs.actions import ActionType
from teamgym.envs.spaces import MaskedDiscrete
from teamgym.maps.geometry import door_opening, shared_edge
from teamgym.maps.model import OfficeMap, Point

if TYPE_CHECKING:
    from teamgym.envs.exploration.config import ExplorationConfig
    from teamgym.envs.exploration.state import ExplorationArrays
    from teamgym.maps.topology import ClutterEstimate, TopologicalModel
    from teamgym.sim.objects import Door
    from teamgym.sim.robot import DiffDriveRobot
    from teamgym.sim.world import World

OPERATOR_KINDS = ("wait", "find_door", "traverse_door", "goto")


@dataclass(frozen=True)
class Operator:
    """One operator with its arguments (ids of the map's doors and sectors)."""

    index: int
    kind: str
    door: str | None = None
    sector: str | None = None
    origin: str | None = None

    @property
    def name(self) -> str:
        if self.kind == "wait":
            return "Wait()"
        if self.kind == "find_door":
            return f"FindDoor({self.door})"
        if self.kind == "traverse_door":
            return f"TraverseDoor({self.door},{self.sector})"
        return f"GoTo({self.origin},{self.sector})"

    @property
    def short(self) -> str:
        """The notation of the paper's Table 1: W(), FD(D), TD(D,S), GT(S)."""
        if self.kind == "wait":
            return "W()"
        if self.kind == "find_door":
            return f"FD({self.door})"
        if self.kind == "traverse_door":
            return f"TD({self.door},{self.sector})"
        return f"GT({self.sector})"


def enumerate_operators(office: OfficeMap) -> tuple[Operator, ...]:
    """All operators of a map in action-index order (see the module docstring)."""
    ops = [Operator(0, "wait")]
    for d in office.doors:
        ops.append(Operator(len(ops), "find_door", door=d.id))
    for d in office.doors:
        for s in d.sectors:
            ops.append(Operator(len(ops), "traverse_door", door=d.id, sector=s))
    for a, b in office.passages:
        ops.append(Operator(len(ops), "goto", sector=b, origin=a))
        ops.append(Operator(len(ops), "goto", sector=a, origin=b))
    return tuple(ops)


class OperatorSet:
    """Preconditions and effects of a map's operators over vertex indices (sectors, then doors)."""

    def __init__(self, office: OfficeMap) -> None:
        self.map = office
        self.operators = enumerate_operators(office)
        self.index = {v: k for k, v in enumerate(office.vertex_ids)}
        self.by_name = {op.name: op.index for op in self.operators}
        self._targets = np.full(len(self.operators), -1, dtype=int)
        self._by_place: dict[int, list[int]] = {}
        for op in self.operators[1:]:
            if op.kind == "find_door":
                places = [self.index[s] for s in office.door(op.door).sectors]
                target = self.index[op.door]
            elif op.kind == "traverse_door":
                places, target = [self.index[op.door]], self.index[op.sector]
            else:
                places, target = [self.index[op.origin]], self.index[op.sector]
            self._targets[op.index] = target
            for place in places:
                self._by_place.setdefault(place, []).append(op.index)

    def __len__(self) -> int:
        return len(self.operators)

    def next_place(self, op: int, place: int) -> int:
        """x_i^{n+1} of eq. (6): where operator ``op`` takes a robot at vertex ``place``."""
        return place if op == 0 else int(self._targets[op])

    def candidates(self, place: int) -> list[int]:
        """Operators whose place precondition holds at ``place`` (Wait first)."""
        return [0, *self._by_place.get(place, [])]

    def admissible(self, place: int, cost: Callable[[int, int], float]) -> np.ndarray:
        """Action mask (int8, 1 = admissible) for a robot at vertex ``place``; ``cost`` is w of eq. (3)."""
        mask = np.zeros(len(self.operators), dtype=np.int8)
        for op in self.candidates(place):
            if op == 0 or math.isfinite(cost(place, int(self._targets[op]))):
                mask[op] = 1
        return mask


class OperatorSpace(MaskedDiscrete):
    """``Discrete`` over operator indices; ``sample()`` draws an admissible operator."""


class OperatorTask(Protocol):
    """What :class:`OperatorAction` reads of its task (Exploration implements it).

    ``_arrays`` holds the episode state of the copies (:class:`~teamgym.envs.exploration.state.ExplorationArrays`:
    sectors, places, contacts, readings, stage clocks, task counters), ``_copy`` is this task's row;
    ``model`` is the team's topological model (eq. 1; costs by eq. 3, beliefs o_j) and
    ``clutter_estimate`` the re-estimate of eq. (2), both over views of that row; ``doors`` are
    the door entities (their true states); ``_poses()`` gives ``(x, y, θ)`` of every robot row.
    """

    _arrays: ExplorationArrays
    _copy: int
    _row: dict[str, int]
    config: ExplorationConfig
    map: OfficeMap
    model: TopologicalModel
    clutter_estimate: ClutterEstimate
    doors: dict[str, Door]
    world: World
    robot_list: list[DiffDriveRobot]
    live_agents: list[str]
    cycles: int

    def _poses(self) -> list[tuple[float, float, float]]: ...


class OperatorAction(ActionType):
    """The paper's operators as macro actions: one ``step`` is one planning stage (Fig. 5).

    The action type owns each robot's task-execution watcher (:class:`~teamgym.control.watcher.TaskWatcher`,
    section 2.2, Fig. 4; with it the behaviour-based controller that executes go-to, find-door and
    traverse-door tasks) and the :class:`TaskFactory` that turns operators into tasks, made per
    episode by :meth:`begin`; it reads its task only through :class:`OperatorTask`.
    :meth:`start` assigns the tasks of a stage, :meth:`act` is the controller's command,
    :meth:`stage_over` watches the tasks and :meth:`mask` gives the preconditions of section 3.1.
    ``config`` gives the watcher's limits (``stall_time``, ``task_timeout``, ``fail_on_collision``),
    ``max_speed`` and the stage rules (``stage_end``, ``wait_steps``, ``max_cycles``).
    """

    name = "operator"
    is_macro = True
    has_masks = True

    def __init__(self, operators: OperatorSet, config: ExplorationConfig | None = None, robot_radius: float = 0.0) -> None:
        self.operators = operators
        self.config = config
        self.robot_radius = robot_radius
        #: Each robot row's watcher in the current episode (:meth:`begin`).
        self.watchers: list[TaskWatcher] = []
        self.tasks: TaskFactory | None = None

    def space(self) -> OperatorSpace:
        return OperatorSpace(len(self.operators))

    def begin(self, env: OperatorTask) -> None:
        """A new episode: a fresh watcher per robot row, tasks that read ``env``'s doors and beliefs."""
        c = self.config
        if c is None:
            raise ValueError("OperatorAction.begin: the action type was made without a config")
        self.watchers = [TaskWatcher(c.stall_time, c.task_timeout, c.fail_on_collision) for _ in env._row]
        door_index = {d: j for j, d in enumerate(env.map.door_ids)}
        self.tasks = TaskFactory(
            env.map,
            partial(_door_is_open, env),
            partial(_door_known_closed, env, door_index),
            self.robot_radius,
            c.max_speed,
        )

    def start(self, env: OperatorTask, actions: dict) -> None:
        """Begin a planning stage (Fig. 5): start the operators; one a robot still executes continues."""
        state, k = env._arrays, env._copy
        if not state.explored_all[k]:
            state.stages[k] += 1
        time, states, row = env.world.time, env.world.robot_states, env._row
        sectors, ids, operators = state.sector[k], env.map.sector_ids, self.operators.operators
        for agent, op in actions.items():
            i = row[agent]
            watcher = self.watchers[i]
            if watcher.executing and watcher.task is not None and watcher.task.key == op:
                continue
            watcher.acknowledge()
            task = self.tasks.make(operators[op], ids[sectors[i]])
            watcher.assign(task, time, states[i, :2], env.robot_list[i].odometer)
            state.task_sector[k, i] = sectors[i]
        in_stage = state.in_stage[k]
        in_stage[:] = False
        in_stage[[row[a] for a in env.live_agents]] = True
        state.stage_start[k] = env.cycles
        state.stage_ended[k] = False

    def act(self, env: OperatorTask, agent: str, action) -> tuple[float, float]:
        """The behaviour-based controller's command for ``agent``'s current task."""
        i, state, k = env._row[agent], env._arrays, env._copy
        return self.watchers[i].control(env._poses()[i], state.proximity[k, i], bool(state.collided[k, i]))

    def stage_over(self, env: OperatorTask) -> bool:
        """After a control step: watch the tasks; the stage ends as ``stage_end`` says."""
        c, state, k = self.config, env._arrays, env._copy
        robots = np.flatnonzero(state.in_stage[k]).tolist()
        for i in robots:
            if self.watch(env, i):
                state.stage_ended[k] = True
        if state.explored_all[k] or env.cycles >= c.max_cycles:
            return True
        watchers = self.watchers
        busy = any(watchers[i].executing and not watchers[i].task.is_wait for i in robots)
        waited = env.cycles - int(state.stage_start[k]) >= c.wait_steps
        ended = bool(state.stage_ended[k])
        if c.stage_end == "any":
            return ended or (not busy and waited)
        return not busy and (ended or waited)

    def watch(self, env: OperatorTask, i: int) -> bool:
        """Update robot row ``i``'s watcher after a control step; True if its task just ended.

        A completed FindDoor re-estimates its sector's clutter (eq. 2); a failed task stops the robot.
        """
        watcher = self.watchers[i]
        if not watcher.executing:
            return False
        state, k = env._arrays, env._copy
        position = env._poses()[i][:2]
        outcome = watcher.after_step(env.world.time, position, env.robot_list[i].odometer, bool(state.collided[k, i]))
        if outcome == WatcherState.COMPLETED:
            state.completed[k, i] += 1
            report = watcher.report
            if self.operators.operators[watcher.task.key].kind == "find_door":
                env.clutter_estimate.observe(int(state.task_sector[k, i]), report.straight, report.travelled)
                env.model.clutter[:] = env.clutter_estimate.values
            return True
        if outcome == WatcherState.FAILED:
            state.failed[k, i] += 1
            env.robot_list[i].set_command(0.0, 0.0)
            return True
        return False

    def mask(self, env: OperatorTask, agent: str) -> np.ndarray:
        """Preconditions of section 3.1 at the robot's place; the operator it executes stays allowed."""
        i = env._row[agent]
        mask = self.operators.admissible(int(env._arrays.place[env._copy, i]), env.model.cost)
        watcher = self.watchers[i]
        if watcher.executing and watcher.task is not None:
            mask[watcher.task.key] = 1
        return mask

    def task_rows(self) -> tuple[list[int], list[int]]:
        """Per robot row: the watcher state (``WatcherState``) and the current operator's index (−1: none)."""
        watchers = self.watchers
        return [int(w.state) for w in watchers], [w.task.key if w.task is not None else -1 for w in watchers]

    def task_metrics(self, i: int) -> dict[str, int]:
        """Robot row ``i``'s task infos: ``task``, ``task_status`` and ``task_reason`` (indices)."""
        watcher = self.watchers[i]
        return {
            "task": watcher.task.key if watcher.task is not None else -1,
            "task_status": int(watcher.state),
            "task_reason": TASK_REASONS.index(watcher.report.reason) if watcher.report is not None else 0,
        }

    def describe(self, action) -> str:
        return self.operators.operators[int(action)].name


def _door_is_open(env: OperatorTask, door: str) -> bool:
    """A door's true state (the tasks' ``door_open``; a module function so that tasks pickle)."""
    return env.doors[door].is_open


def _door_known_closed(env: OperatorTask, door_index: dict[str, int], door: str) -> bool:
    """Whether the team's model knows the door is closed (the tasks' ``door_known_closed``)."""
    return env.model.door_open[door_index[door]] <= 0.0


class TaskFactory:
    """Turns operators into controller tasks on a map (waypoints, completion tests, parameters).

    ``door_open(door_id)`` reports a door's true state (a robot inside the door's circle sees
    it), ``door_known_closed(door_id)`` whether the team knows it is closed (then a task using
    the door fails with "door closed"); ``approach`` is how far in front of a door (m)
    FindDoor aims, ``exit_margin`` how far past the door circle TraverseDoor ends.
    """

    def __init__(
        self,
        office: OfficeMap,
        door_open: Callable[[str], bool],
        door_known_closed: Callable[[str], bool],
        robot_radius: float,
        max_speed: float,
        approach: float = 0.05,
        exit_margin: float = 0.04,
    ) -> None:
        self.map = office
        self.door_open = door_open
        self.door_known_closed = door_known_closed
        self.robot_radius = robot_radius
        self.approach = approach
        self.exit_margin = exit_margin
        base = BehaviourParameters(v_max=max_speed)
        passage = list(DEFAULT_PRIORITIES)
        passage[NARROW_PASSAGE] = 0.95
        self.params = {
            "wait": base,
            "find_door": base,
            "traverse_door": replace(base, v_max=0.7 * max_speed, priorities=tuple(passage)),
            "goto": base,
        }

    def normal(self, door_id: str, sector_id: str) -> Point:
        """Unit normal of the door's wall pointing into ``sector_id``."""
        axis, c, _, _ = door_opening(self.map, self.map.door(door_id))
        s = self.map.sector(sector_id)
        if axis == "x":
            return (1.0, 0.0) if s.x_min >= c - 1e-9 else (-1.0, 0.0)
        return (0.0, 1.0) if s.y_min >= c - 1e-9 else (0.0, -1.0)

    def _point(self, door_id: str, sector_id: str, offset: float) -> Point:
        cx, cy = self.map.door(door_id).centre
        nx, ny = self.normal(door_id, sector_id)
        return (cx + offset * nx, cy + offset * ny)

    def make(self, op: Operator, sector: str) -> Task:
        """The task for ``op`` given to a robot currently in sector ``sector``."""
        params = self.params[op.kind]
        if op.kind == "wait":
            return Task(op.name, (), None, params, key=op.index)
        office = self.map
        if op.kind == "find_door":
            door = office.door(op.door)
            side = sector if sector in door.sectors else door.sectors[0]
            inside = self._inside(door.centre, door.radius)
            closed = self._closed_check(op.door, partial(_inside_or_known_closed, inside, self.door_known_closed, op.door))
            return Task(
                op.name,
                (self._point(op.door, side, self.approach),),
                partial(_inside_and_open, inside, self.door_open, op.door),
                params,
                closed,
                key=op.index,
            )
        if op.kind == "traverse_door":
            door = office.door(op.door)
            target = office.sector(op.sector)
            exit_point = self._point(op.door, op.sector, door.radius + self.exit_margin)
            waypoints = (exit_point,)
            if sector != op.sector and sector in door.sectors:
                waypoints = (self._point(op.door, sector, 0.6 * self.approach), exit_point)
            inside = self._inside(door.centre, door.radius)
            margin = 0.002
            crossing = self._closed_check(op.door, partial(_outside, target, margin))
            return Task(op.name, waypoints, partial(_entered, target, margin, inside), params, crossing, key=op.index)
        origin, target = office.sector(op.origin), office.sector(op.sector)
        axis, c, lo, hi = shared_edge(origin, target)
        middle = (c, 0.5 * (lo + hi)) if axis == "x" else (0.5 * (lo + hi), c)
        return Task(op.name, (middle, target.centre), partial(_contains, target, self.robot_radius), params, key=op.index)

    @staticmethod
    def _inside(centre: Point, radius: float) -> Callable[[float, float], bool]:
        return partial(_within, centre, radius)

    def _closed_check(self, door_id: str, near: Callable[[float, float], bool]) -> Callable[[float, float], str | None]:
        return partial(_door_closed_near, self.door_open, self.door_known_closed, door_id, near)


# The tests above are partials of module functions (not lambdas), so that a task pickles with the env.
def _within(centre: Point, radius: float, x: float, y: float) -> bool:
    return math.hypot(x - centre[0], y - centre[1]) < radius


def _inside_and_open(inside: Callable, door_open: Callable, door: str, x: float, y: float) -> bool:
    return inside(x, y) and door_open(door)


def _inside_or_known_closed(inside: Callable, door_known_closed: Callable, door: str, x: float, y: float) -> bool:
    return inside(x, y) or door_known_closed(door)


def _outside(target, margin: float, x: float, y: float) -> bool:
    return not target.contains(x, y, margin)


def _entered(target, margin: float, inside: Callable, x: float, y: float) -> bool:
    return target.contains(x, y, margin) and not inside(x, y)


def _contains(target, margin: float, x: float, y: float) -> bool:
    return target.contains(x, y, margin)


def _door_closed_near(
    door_open: Callable, door_known_closed: Callable, door: str, near: Callable, x: float, y: float
) -> str | None:
    closed = door_known_closed(door) or not door_open(door)
    return "door closed" if near(x, y) and closed else None
