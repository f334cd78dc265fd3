"""Several worlds stepped together: the step hooks of all their robots and obstacles in one numpy pass.

A batch of env copies (:class:`~teamgym.envs.batch.TeamBatch`) steps K worlds of one layout
every control step. :meth:`World.step <teamgym.sim.world.World.step>` runs each world's step
hooks (:class:`~teamgym.sim.robot.RobotSteps`, :class:`~teamgym.sim.objects.BounceSteps`) on
that world's few entities; :func:`step_worlds` runs them once over the entities of all the
worlds — the robots' arc motions (:meth:`DiffDriveRobot.apply_command
<teamgym.sim.robot.DiffDriveRobot.apply_command>`), the obstacles' bounces
(:meth:`MovingPolygon.plan_bounce <teamgym.sim.objects.MovingPolygon.plan_bounce>`) and the
encoders and odometers (:meth:`DiffDriveRobot.end_step <teamgym.sim.robot.DiffDriveRobot.end_step>`)
— with the same floating-point operations in the same order, so every world ends its step
bit for bit as if it had stepped alone. What stays per world is what Chipmunk needs per space:
the control bodies' writes, the pivot anchors, the substeps and one batch read — made from one
compiled call for all worlds where :mod:`teamgym.sim.kernel` is enabled (:class:`CompiledWorlds`),
else world by world from Python.

A world takes the group path when its plan holds only those step groups, it integrates a
whole step in ``substeps`` (no adaptive substeps) and no robot has an actuation delay this
step; any other world steps alone (``World.step``), so the result never depends on the path.
"""

from __future__ import annotations

import math
import operator
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from teamgym.sim import kernel
from teamgym.sim.entity import StepGroup
from teamgym.sim.libm import libm
from teamgym.sim.objects import BounceSteps, MovingPolygon
from teamgym.sim.robot import DiffDriveRobot, RobotSteps, arc_motion, encoder_values
from teamgym.sim.world import World, pending_work_in

__all__ = [
    "MIN_ROBOTS_TOGETHER",
    "MIN_ROBOTS_TOGETHER_COMPILED",
    "CompiledWorlds",
    "GroupPlan",
    "GroupPlans",
    "StepTogether",
    "default_min_robots",
    "group_plan",
    "step_worlds",
]


@dataclass(frozen=True)
class GroupPlan:
    """What :func:`step_worlds` needs of one world: its robots and bouncing obstacles with their rows."""

    robots: list[DiffDriveRobot]
    #: Rows of the robots in the world's state rows / of their control bodies in its body buffer
    #: (``None``: the buffer cannot be written, the control bodies are set one by one).
    robot_rows: slice | np.ndarray
    control_rows: np.ndarray | None
    movers: list[MovingPolygon]
    mover_rows: slice | np.ndarray
    #: The robots' half wheel bases and wheel radii, the obstacles' bounding radii and the arena
    #: size ``(w, h)`` per obstacle: constants of the plan, gathered once.
    half_base: np.ndarray
    wheel_radius: np.ndarray
    mover_radius: np.ndarray
    mover_size: np.ndarray
    #: The world's compiled part (:class:`CompiledPart`), made when a compiled group first needs it.
    memo: dict = field(default_factory=dict, compare=False, repr=False)


def group_plan(world: World) -> GroupPlan | None:
    """The world's :class:`GroupPlan`, or ``None`` when it must step alone (see the module docstring)."""
    if world.coarse_substeps > 0:
        return None
    robots: list = []
    robot_rows: list[int] = []
    movers: list = []
    mover_rows: list[int] = []
    for group, rows in world.step_plan():
        span = list(range(rows.start, rows.stop))
        if isinstance(group, RobotSteps):
            robots += group.entities
            robot_rows += span
        elif isinstance(group, BounceSteps):
            movers += [m for m in group.entities if m.bounce]
            mover_rows += [row for row, m in zip(span, group.entities) if m.bounce]
        elif type(group) is not StepGroup or any(_has_hooks(entity) for entity in group.entities):
            return None
    if not robots:
        return None
    control_rows = world.body_rows([robot.control for robot in robots])
    return GroupPlan(
        robots,
        _rows(robot_rows),
        control_rows,
        movers,
        _rows(mover_rows),
        half_base=0.5 * np.array([robot.spec.wheel_base for robot in robots]),
        wheel_radius=np.array([robot.spec.wheel_radius for robot in robots]),
        mover_radius=np.array([mover.bounding_radius for mover in movers]),
        mover_size=np.array([world.size for _ in movers], dtype=float).reshape(-1, 2),
    )


def _rows(rows: list[int]) -> slice | np.ndarray:
    """State rows as a slice when they are consecutive (a view, no copy), else an index array."""
    if rows and rows == list(range(rows[0], rows[0] + len(rows))):
        return slice(rows[0], rows[0] + len(rows))
    return np.array(rows, dtype=np.intp)


#: Robots a group of worlds needs to step together (:class:`GroupPlans`) when they step in Python.
#: Gathering the group into arrays costs a fixed few tens of µs per control step, which the one
#: pass saves back only over many robots. Measured on 2026-12-07 (``benchmarks/bench_world_group.py``,
#: same process, together / one by one): 1.08–1.16× the time at 4 copies of Navigation,
#: BoxPushing-v0 and Exploration; at 64 copies 0.96–1.04× over repeated runs.
MIN_ROBOTS_TOGETHER = 128

#: The same with the compiled kernel (:mod:`teamgym.sim.kernel`), which makes the Chipmunk calls
#: of a group in one call: together / one by one 0.99–1.06× at 4 copies, 0.94–0.97× at 8 and
#: 0.85–0.93× at 16 (2026-12-07, same benchmark). The smaller of the two thresholds applies.
MIN_ROBOTS_TOGETHER_COMPILED = 16


def default_min_robots() -> int:
    """The fewest robots a group steps together with by default: compiled or not (see the two thresholds)."""
    if kernel.enabled():
        return min(MIN_ROBOTS_TOGETHER, MIN_ROBOTS_TOGETHER_COMPILED)
    return MIN_ROBOTS_TOGETHER


class GroupPlans:
    """:func:`group_plan` of worlds, each kept while its world keeps its step plan (its entities).

    ``min_robots``: the fewest robots (over the plans of the worlds) with which a group steps
    together (default :func:`default_min_robots`, taken when a group first needs it, so a lone
    env never loads the kernel); smaller groups step world by world (the same bits either way).
    """

    def __init__(self, min_robots: int | None = None) -> None:
        self._plans: weakref.WeakKeyDictionary[World, tuple[list, GroupPlan | None]] = weakref.WeakKeyDictionary()
        self._together: StepTogether | None = None
        self._whole: StepTogether | None = None  # the last group made from its worlds (subsets are picked from it)
        self._last: list[World] | None = None  # the worlds of the last step that stepped alone
        self._small = False  # whether those worlds hold too few robots to step together
        self._min_robots_given = min_robots  # kept by pickles (None: the default when unpickled)
        self._min_robots = min_robots

    @property
    def min_robots(self) -> int:
        if self._min_robots is None:
            self._min_robots = default_min_robots()
        return self._min_robots

    def plan_of(self, world: World) -> GroupPlan | None:
        steps = world.step_plan()
        known = self._plans.get(world)
        if known is None or known[0] is not steps:
            known = (steps, group_plan(world))
            self._plans[world] = known
        return known[1]

    def step(self, worlds: Sequence[World], reuse_states: bool = False) -> np.ndarray | None:
        """Step ``worlds`` one control step: together (:class:`StepTogether`) when they hold at least
        ``min_robots`` robots — with the compiled kernel from a group's first step, else once the
        same worlds step twice in a row.

        A group that changes from step to step (copies of a macro action type leaving their
        stage one by one) gathers its robots anew every step. In Python that costs more than it
        saves, so a new group steps its worlds alone the first time; the kernel joins the
        worlds' arrays made once per step plan (:class:`CompiledPart`), which costs little.

        Returns the group's :attr:`StepTogether.robot_states` (every world's ``robot_states`` after the
        step as one ``(worlds, robots, 6)`` array) when it gives them, else ``None``.
        """
        together = self._together
        if together is not None and together.same_worlds(worlds):
            if together.same_step_plans():  # then plan_of would give every world the plan it has in ``together``
                together.step(reuse_states)
                return together.robot_states
            plans = [self.plan_of(world) for world in worlds]
            if not together.matches(worlds, plans):
                together = self._together = self._whole = StepTogether(worlds, plans)
            together.step(reuse_states)
            return together.robot_states
        if kernel.enabled():
            plans = [self.plan_of(world) for world in worlds]
            part = self._part_of_whole(worlds, plans)
            if part is not None:
                self._together = part
                part.step(reuse_states)
                return part.robot_states
            if sum(len(plan.robots) for plan in plans if plan is not None) >= self.min_robots:
                self._together = self._whole = StepTogether(worlds, plans)
                self._together.step(reuse_states)
                return self._together.robot_states
        elif self._last is not None and len(self._last) == len(worlds) and all(a is b for a, b in zip(self._last, worlds)):
            if not self._small:
                plans = [self.plan_of(world) for world in worlds]
                if sum(len(plan.robots) for plan in plans if plan is not None) >= self.min_robots:
                    self._together = StepTogether(worlds, plans)
                    self._together.step(reuse_states)
                    return self._together.robot_states
                self._small = True
        else:
            self._last, self._small = list(worlds), False
        for world in worlds:
            world.step(reuse_states=reuse_states)
        return None

    def _part_of_whole(self, worlds: Sequence[World], plans: list[GroupPlan | None]) -> StepTogether | None:
        """The last whole group's :meth:`StepTogether.subset` for ``worlds`` when they are some of its worlds, in its
        order, with the same plans and its compiled step (copies leaving a macro stage), and hold ``min_robots``
        robots; else None."""
        whole = self._whole
        if whole is None or whole._compiled is None or len(worlds) >= len(whole.worlds):
            return None
        if sum(len(plan.robots) for plan in plans if plan is not None) < self.min_robots:
            return None  # a small group steps world by world (see min_robots)
        positions = whole.positions_of(worlds)
        if positions is None or any(a is not whole.plans[m] for a, m in zip(plans, positions.tolist())):
            return None
        return whole.subset(positions)

    def __getstate__(self) -> dict:
        return {"min_robots": self._min_robots_given}  # plans are made again (they hold Chipmunk handles)

    def __setstate__(self, state: dict) -> None:
        self.__init__(state.get("min_robots"))


def _has_hooks(entity: object) -> bool:
    """Whether an entity in a plain step group overrides a step hook (then its world steps alone)."""
    from teamgym.sim.entity import Entity

    cls = type(entity)
    return any(getattr(cls, name) is not getattr(Entity, name) for name in ("before_step", "mid_step", "after_step"))


def step_worlds(worlds: Sequence[World], plans: Sequence[GroupPlan | None], reuse_states: bool = False) -> None:
    """Advance every world one control step, as ``world.step(reuse_states)`` each would.

    ``plans[i]`` is :func:`group_plan` of ``worlds[i]`` (:class:`GroupPlans` keeps them while the
    worlds keep their entities). Worlds without a plan, or with a robot in an actuation delay, step alone.
    """
    StepTogether(worlds, plans).step(reuse_states)


class StepTogether:
    """The robots and obstacles of worlds that step together, gathered once (a batch reuses it while its copies keep them)."""

    def __init__(self, worlds: Sequence[World], plans: Sequence[GroupPlan | None]) -> None:
        self.worlds, self.plans = list(worlds), list(plans)
        pairs = [(world, plan) for world, plan in zip(worlds, plans) if plan is not None]
        self.together = pairs
        self._spaces = [world.space for world, _ in pairs]
        self._step_plans = [world.step_plan() for world in self.worlds]  # what ``plans`` were made from
        self._note_robot_rows()
        self.robots = [robot for _, plan in pairs for robot in plan.robots]
        self.movers = [mover for _, plan in pairs for mover in plan.movers]
        self.bounds = np.cumsum([0] + [len(plan.robots) for _, plan in pairs]).tolist()
        plans_together = [plan for _, plan in pairs]
        self.half_base = _joined([plan.half_base for plan in plans_together])
        self.wheel_radius = _joined([plan.wheel_radius for plan in plans_together])
        self.mover_radius = _joined([plan.mover_radius for plan in plans_together])
        self.mover_size = _joined([plan.mover_size for plan in plans_together], (0, 2))
        #: Per world: its index in ``together`` (−1: it steps alone); per robot and obstacle: its world in ``together``.
        self._pair_of = np.cumsum([plan is not None for plan in plans]) - 1
        self._pair_of[[plan is None for plan in plans]] = -1
        self._robot_world = np.repeat(np.arange(len(pairs)), [len(plan.robots) for plan in plans_together])
        self._mover_world = np.repeat(np.arange(len(pairs)), [len(plan.movers) for plan in plans_together])
        self._compiled: CompiledWorlds | None = None
        self._compiled_tried = False
        self._positions: dict[int, int] | None = None  # id(world) -> its position (made when first asked)

    def positions_of(self, worlds: Sequence[World]) -> np.ndarray | None:
        """Positions of ``worlds`` among this object's worlds if they are some of them in the same order, else None."""
        if self._positions is None:
            self._positions = {id(world): m for m, world in enumerate(self.worlds)}
        get = self._positions.get
        positions = [get(id(world), -1) for world in worlds]
        if not positions or min(positions) < 0 or any(a >= b for a, b in zip(positions, positions[1:])):
            return None
        return np.array(positions, dtype=np.intp)

    def subset(self, positions: np.ndarray) -> StepTogether:
        """The same for the worlds at ``positions`` (ascending) only: arrays picked, nothing gathered again.

        A batch whose copies leave a macro stage one by one steps a smaller group at every control step;
        picking the group's rows from the whole group's costs a few array operations.
        """
        new = object.__new__(StepTogether)
        picked = positions.tolist()
        new.worlds, new.plans = [self.worlds[m] for m in picked], [self.plans[m] for m in picked]
        pairs = self._pair_of[positions]
        sel = pairs[pairs >= 0]
        new.together = [self.together[m] for m in sel.tolist()]
        new._spaces = [self._spaces[m] for m in sel.tolist()]
        new._step_plans = [self._step_plans[m] for m in picked]
        if self._robots_each is None:
            new._note_robot_rows()
        else:  # every world of the whole group holds the same number of robots, all stepped together: so do these
            new._robots_each, new.robot_states = self._robots_each, None
        rank = np.full(len(self.together), -1)
        rank[sel] = np.arange(len(sel))
        robots = np.flatnonzero(rank[self._robot_world] >= 0)
        movers = np.flatnonzero(rank[self._mover_world] >= 0)
        new.robots = [self.robots[r] for r in robots.tolist()]
        new.movers = [self.movers[r] for r in movers.tolist()]
        new.bounds = np.cumsum([0, *np.diff(self.bounds)[sel].tolist()]).tolist()
        new.half_base, new.wheel_radius = self.half_base[robots], self.wheel_radius[robots]
        new.mover_radius, new.mover_size = self.mover_radius[movers], self.mover_size[movers]
        new._pair_of = np.where(pairs >= 0, rank[np.maximum(pairs, 0)], -1)
        new._robot_world, new._mover_world = rank[self._robot_world[robots]], rank[self._mover_world[movers]]
        new._compiled = None if self._compiled is None else self._compiled.subset(sel)
        new._compiled_tried = self._compiled_tried
        new._positions = None
        return new

    def same_worlds(self, worlds: Sequence[World]) -> bool:
        """Whether ``worlds`` are the worlds this object was made for (in that order)."""
        return len(worlds) == len(self.worlds) and all(a is b for a, b in zip(worlds, self.worlds))

    def _note_robot_rows(self) -> None:
        """Whether the robots stepped together are every world's robots, the same number in each (then :attr:`robot_states`
        can hold them as one ``(worlds, robots, 6)`` array)."""
        counts = {len(plan.robots) if plan is not None and len(plan.robots) == len(world.robots) else -1
                  for world, plan in zip(self.worlds, self.plans)}  # fmt: skip
        self._robots_each = counts.pop() if len(counts) == 1 and -1 not in counts else None
        #: Every world's ``robot_states`` after the last step, ``(worlds, robots, 6)``, when every world stepped in the
        #: group and each holds the same number of robots; else ``None``.
        self.robot_states: np.ndarray | None = None

    def same_step_plans(self) -> bool:
        """Whether every world keeps the step plan this object's ``plans`` were made from (no entity added or removed)."""
        return all(map(operator.is_, [world.step_plan() for world in self.worlds], self._step_plans))

    def matches(self, worlds: Sequence[World], plans: Sequence[GroupPlan | None]) -> bool:
        """Whether these are the worlds and plans this object was made for."""
        return (
            len(worlds) == len(self.worlds)
            and all(a is b for a, b in zip(worlds, self.worlds))
            and all(a is b for a, b in zip(plans, self.plans))
        )

    def step(self, reuse_states: bool) -> None:
        """One control step of every world (the ones without a plan or with a delay alone)."""
        delayed = any(robot.actuation_delay > 0.0 for robot in self.robots)
        self.robot_states = None
        for world, plan in zip(self.worlds, self.plans):
            if plan is None or delayed:
                world.step(reuse_states=reuse_states)
        if self.together and not delayed:
            ends = self._step_together(reuse_states)
            if self._robots_each is not None:
                self.robot_states = ends.reshape(len(self.worlds), self._robots_each, ends.shape[1])

    def _step_together(self, reuse_states: bool) -> np.ndarray:
        """The robots' arc motions, the substeps (compiled or world by world), their encoders; their state rows after."""
        together, robots = self.together, self.robots
        compiled = self._compiled_worlds()
        if compiled is not None and not pending_work_in(self._spaces):
            states = compiled.start(reuse_states)
            starts, mover_states = states[compiled.robot_rows], states[compiled.mover_rows]
        else:
            compiled = None
            blocks = [world.begin_step(reuse_states) for world, _ in together]
            starts = np.concatenate([block[plan.robot_rows] for block, (_, plan) in zip(blocks, together)])
            mover_states = np.concatenate([block[plan.mover_rows] for block, (_, plan) in zip(blocks, together)])
        commands = np.array([robot.command for robot in robots], dtype=float).reshape(-1, 2)
        motion, anchors = arc_motion(commands, starts)
        dt = together[0][0].dt
        bounced = self._plan_bounces(mover_states, dt)
        ends = self._step_in_python(motion, anchors, bounced) if compiled is None else compiled.step(motion, anchors, bounced)
        _end_robot_steps(robots, commands, starts, ends, dt, self.half_base, self.wheel_radius)
        return ends

    def _step_in_python(self, motion: np.ndarray, anchors: np.ndarray, bounced: list[tuple[MovingPolygon, tuple]]) -> np.ndarray:
        """Write the control bodies, anchors and bounces world by world, integrate, read: the robots' end rows."""
        together, bounds = self.together, self.bounds
        anchor_list = anchors.tolist()
        for m, (world, plan) in enumerate(together):
            first, last = bounds[m], bounds[m + 1]
            if plan.control_rows is not None:
                world.write_bodies(plan.control_rows, motion[first:last])
                for robot, anchor in zip(plan.robots, anchor_list[first:last]):
                    robot._set_anchor(anchor)
            else:
                for robot, row, anchor in zip(plan.robots, motion[first:last].tolist(), anchor_list[first:last]):
                    robot.set_control_motion(row, anchor)
                world.bodies_moved()
        for mover, velocity in bounced:
            mover.target_velocity = velocity
            mover.control.velocity = velocity
        for world, _ in together:
            world.integrate_step()
        ends = np.concatenate([world.finish_step()[plan.robot_rows] for world, plan in together])
        return ends

    def _compiled_worlds(self) -> CompiledWorlds | None:
        """The compiled step of these worlds (:mod:`teamgym.sim.kernel`), made at the first step; ``None`` without it."""
        if not kernel.enabled():
            return None
        if not self._compiled_tried:
            self._compiled_tried = True
            try:
                self._compiled = CompiledWorlds(self.together)
            except ValueError:  # worlds with different dt or substeps step in Python
                self._compiled = None
        return self._compiled

    def _plan_bounces(self, state: np.ndarray, dt: float) -> list[tuple[MovingPolygon, tuple]]:
        """:meth:`MovingPolygon.plan_bounce` of every bouncing obstacle at once (``state``: their state rows at the
        step's start); the obstacles whose velocity changes."""
        movers = self.movers
        if not movers:
            return []
        target = np.array([mover.target_velocity for mover in movers], dtype=float)
        radius, size = self.mover_radius, self.mover_size
        x, y, actual_x, actual_y = state[:, 0], state[:, 1], state[:, 3], state[:, 4]
        vx, vy = target[:, 0], target[:, 1]
        flip_x = ((x + vx * dt + radius > size[:, 0]) & (vx > 0)) | ((x + vx * dt - radius < 0.0) & (vx < 0))
        flip_y = ((y + vy * dt + radius > size[:, 1]) & (vy > 0)) | ((y + vy * dt - radius < 0.0) & (vy < 0))
        vx = np.where(flip_x, -vx, vx)
        vy = np.where(flip_y, -vy, vy)
        same = (vx == target[:, 0]) & (vy == target[:, 1])
        held = same & (actual_x * vx + actual_y * vy < 0.25 * (vx * vx + vy * vy))
        vx = np.where(held, -vx, vx)
        vy = np.where(held, -vy, vy)
        changed = np.flatnonzero((vx != target[:, 0]) | (vy != target[:, 1])).tolist()
        return [(movers[i], (float(vx[i]), float(vy[i]))) for i in changed]


@dataclass(frozen=True)
class CompiledPart:
    """One world's share of a :class:`CompiledWorlds`, kept with its :class:`GroupPlan` (made once per plan).

    Rows are the world's own (its space's iteration order, its state rows); :class:`CompiledWorlds`
    offsets them by the worlds before it.
    """

    layout: kernel.SpaceLayout
    state_rows: np.ndarray  # each state body's row in the space's iteration order
    robot_rows: np.ndarray  # the robots' rows among the state rows
    mover_rows: np.ndarray  # the bouncing obstacles' rows among the state rows
    controls: np.ndarray  # the robots' control bodies (handles)
    joints: np.ndarray  # every drive's pivot joint (handles), robot after robot
    joint_owner: np.ndarray  # each drive's robot (index into the plan's robots)
    joint_offset: np.ndarray  # a wheel drive's wheel point (0 for a centre pivot)
    joint_plain: np.ndarray  # whether the drive is the robot's centre pivot
    mover_controls: dict[int, int]  # id(obstacle) -> handle of its control body

    @classmethod
    def of(cls, world: World, plan: GroupPlan) -> CompiledPart:
        layout = kernel.SpaceLayout.of(world.space)
        every = np.arange(len(world.state_bodies()))
        joints, owners, offsets, plain = [], [], [], []
        for i, robot in enumerate(plan.robots):
            if robot.pivot is not None:
                joints.append(robot.pivot), owners.append(i), offsets.append((0.0, 0.0)), plain.append(True)
            else:
                for drive, point in zip(robot.drives, robot.wheel_points):
                    joints.append(drive), owners.append(i), offsets.append(point), plain.append(False)
        return cls(
            layout,
            layout.body_rows(world.state_bodies()),
            every[plan.robot_rows],
            every[plan.mover_rows],
            kernel.body_handles([robot.control for robot in plan.robots]),
            kernel.joint_handles(joints),
            np.array(owners, dtype=np.intp),
            np.array(offsets, dtype=float).reshape(-1, 2),
            np.array(plain, dtype=bool),
            {id(mover): int(handle) for mover, handle in zip(plan.movers, kernel.body_handles([m.control for m in plan.movers]))},
        )


class CompiledWorlds:
    """Worlds of a :class:`StepTogether` stepped by :class:`teamgym.sim.kernel.WorldsKernel`: their bodies as handles and rows.

    The kernel makes the Chipmunk calls of :meth:`StepTogether._step_in_python` (control bodies,
    drive anchors, bounce velocities, the substeps, the reads) for all worlds in one compiled
    call. Each world's handles and rows (:class:`CompiledPart`) are made once per step plan and
    kept with it, so a group that changes from step to step (copies leaving a macro stage one by
    one) is put together again by joining arrays; this object joins them, finds every world's
    state rows in the kernel's buffer and hands each world its rows after the step.
    """

    def __init__(self, together: Sequence[tuple[World, GroupPlan]]) -> None:
        self.worlds = [world for world, _ in together]
        self._plans = [plan for _, plan in together]
        first = self.worlds[0]
        self.dt, self.substeps = first.dt, first.substeps
        if any(world.dt != self.dt or world.substeps != self.substeps for world in self.worlds):
            raise ValueError("CompiledWorlds: the worlds step with different dt or substeps")
        #: Every world's state rows after the last step (``None``: read them at the next start).
        self.states: np.ndarray | None = None
        self._handed: list[np.ndarray] = []  # the views of ``states`` each world was handed
        self._join()

    def _parts(self) -> list[CompiledPart]:
        parts = []
        for world, plan in zip(self.worlds, self._plans):
            part = plan.memo.get("compiled")
            if part is None:
                part = plan.memo["compiled"] = CompiledPart.of(world, plan)
            parts.append(part)
        return parts

    def _join(self) -> None:
        """The kernel over the worlds' spaces and every array of the group, joined from the worlds' parts."""
        parts = self._parts()
        self.kernel = kernel.WorldsKernel([part.layout for part in parts])
        body_offsets = self.kernel.offsets.tolist()
        self.state_rows = np.concatenate([part.state_rows + offset for part, offset in zip(parts, body_offsets)])
        self.state_bounds = np.cumsum([0] + [len(part.state_rows) for part in parts]).tolist()
        firsts = self.state_bounds
        self.robot_rows = np.concatenate([part.robot_rows + first for part, first in zip(parts, firsts)])
        self.mover_rows = np.concatenate([part.mover_rows + first for part, first in zip(parts, firsts)])
        self.controls = np.concatenate([part.controls for part in parts])
        robot_firsts = np.cumsum([0] + [len(part.controls) for part in parts]).tolist()
        self.joints = np.concatenate([part.joints for part in parts])
        self.joint_owner = np.concatenate([part.joint_owner + first for part, first in zip(parts, robot_firsts)])
        self.joint_offset = np.concatenate([part.joint_offset for part in parts])
        self.joint_plain = np.concatenate([part.joint_plain for part in parts])
        self.mover_controls = {key: handle for part in parts for key, handle in part.mover_controls.items()}
        self.states = None
        self._handed = []
        self._index_rows(
            [len(part.state_rows) for part in parts],
            [len(part.controls) for part in parts],
            [len(part.mover_rows) for part in parts],
            [len(part.joints) for part in parts],
        )

    def _index_rows(self, states: list[int], robots: list[int], movers: list[int], joints: list[int]) -> None:
        """The world of every state row, robot, obstacle row and drive, and the rows within their world: what
        :meth:`subset` picks by (``states`` … ``joints``: how many each world has)."""
        worlds = np.arange(len(states))
        self._state_world = np.repeat(worlds, states)
        self._robot_world = np.repeat(worlds, robots)
        self._mover_world = np.repeat(worlds, movers)
        self._joint_world = np.repeat(worlds, joints)
        self._sizes = np.array([self.kernel.counts, states, robots], dtype=np.int64).reshape(3, len(states))
        before = np.cumsum(self._sizes, axis=1) - self._sizes  # each world's first body, state row and robot
        self._local = (
            self.state_rows - before[0][self._state_world],
            self.robot_rows - before[1][self._robot_world],
            self.mover_rows - before[1][self._mover_world],
            self.joint_owner - before[2][self._joint_world],
        )

    def subset(self, worlds: np.ndarray) -> CompiledWorlds:
        """The same over the worlds ``worlds`` (indices, ascending): rows offset anew, a kernel of their spaces.

        Each picked world's last read starts its next step (as ``World.begin_step(reuse_states=True)``
        takes it), so a step that may reuse them reads nothing again.
        """
        new = object.__new__(CompiledWorlds)
        picked = worlds.tolist()
        new.worlds, new._plans = [self.worlds[m] for m in picked], [self._plans[m] for m in picked]
        new.dt, new.substeps = self.dt, self.substeps
        new.kernel = self.kernel.subset(worlds)
        rank = np.full(len(self.worlds), -1)
        rank[worlds] = np.arange(len(picked))
        sizes = self._sizes[:, worlds]
        after = np.zeros((3, len(self.worlds)), dtype=np.int64)
        after[:, worlds] = np.cumsum(sizes, axis=1) - sizes  # each picked world's first row in the subset
        keep = rank >= 0
        states, robots = np.flatnonzero(keep[self._state_world]), np.flatnonzero(keep[self._robot_world])
        movers, joints = np.flatnonzero(keep[self._mover_world]), np.flatnonzero(keep[self._joint_world])
        state_world, robot_world = self._state_world[states], self._robot_world[robots]
        mover_world, joint_world = self._mover_world[movers], self._joint_world[joints]
        local_states, local_robots, local_movers, local_owners = self._local
        new.state_rows = local_states[states] + after[0][state_world]
        new.robot_rows = local_robots[robots] + after[1][robot_world]
        new.mover_rows = local_movers[movers] + after[1][mover_world]
        new.joint_owner = local_owners[joints] + after[2][joint_world]
        new.state_bounds = [0, *np.cumsum(sizes[1]).tolist()]
        new.controls, new.joints = self.controls[robots], self.joints[joints]
        new.joint_offset, new.joint_plain = self.joint_offset[joints], self.joint_plain[joints]
        new.mover_controls = self.mover_controls
        new._state_world, new._robot_world = rank[state_world], rank[robot_world]
        new._mover_world, new._joint_world = rank[mover_world], rank[joint_world]
        new._sizes = sizes
        new._local = (local_states[states], local_robots[robots], local_movers[movers], local_owners[joints])
        new._handed = [world.states for world in new.worlds]
        fresh = all(states is not None and len(states) == size for states, size in zip(new._handed, sizes[1].tolist()))
        new.states = np.concatenate(new._handed) if fresh else None
        return new

    def _rejoin(self) -> None:
        """Bodies were added or removed behind the worlds' backs: make every world's part again."""
        for plan in self._plans:
            plan.memo.pop("compiled", None)
        self._join()

    def start(self, reuse_states: bool) -> np.ndarray:
        """Begin a step (each world forgets its last step's contacts); every world's state rows at its start.

        With ``reuse_states`` (no body moved since the last read) and every world still holding the
        rows this object handed it after the last step, those rows; else every body is read again.
        """
        for world in self.worlds:
            world.forget_step_contacts()
        if reuse_states and self.states is not None and all(w.states is s for w, s in zip(self.worlds, self._handed)):
            return self.states
        try:
            buffer = self.kernel.read()
        except kernel.KernelError:
            self._rejoin()
            buffer = self.kernel.read()
        self.states = buffer[self.state_rows]
        return self.states

    def step(self, motion: np.ndarray, anchors: np.ndarray, bounced: list[tuple[MovingPolygon, tuple]]) -> np.ndarray:
        """One control step (as :meth:`StepTogether._step_in_python`) after :meth:`start`; the robots' state rows after it."""
        anchor_y = anchors[self.joint_owner]
        anchor_values = np.empty((len(anchor_y), 2))
        # a pivot's anchor is (0, y) as given; a wheel drive's is offset by its wheel point
        anchor_values[:, 0] = np.where(self.joint_plain, 0.0, 0.0 + self.joint_offset[:, 0])
        anchor_values[:, 1] = np.where(self.joint_plain, anchor_y, anchor_y + self.joint_offset[:, 1])
        movers = np.array([self.mover_controls[id(mover)] for mover, _ in bounced], dtype=np.uint64)
        velocities = np.array([velocity for _, velocity in bounced], dtype=float).reshape(-1, 2)
        for mover, velocity in bounced:
            mover.target_velocity = velocity
        h, n = self.dt / self.substeps, self.substeps
        try:
            buffer = self.kernel.step(self.controls, motion, movers, velocities, self.joints, anchor_values, n, h)
        except kernel.KernelError:  # stepped, but a world's bodies changed behind its back: read them again
            self._rejoin()
            buffer = self.kernel.read()
        states = self.states = buffer[self.state_rows]
        bounds = self.state_bounds
        self._handed = [states[bounds[m] : bounds[m + 1]] for m in range(len(self.worlds))]
        for world, rows in zip(self.worlds, self._handed):
            world.end_step_with(rows)
        return states[self.robot_rows]


def _joined(arrays: list[np.ndarray], empty: tuple[int, ...] = (0,)) -> np.ndarray:
    return np.concatenate(arrays) if arrays else np.zeros(empty)


def _end_robot_steps(
    robots: list[DiffDriveRobot],
    commands: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    dt: float,
    half_base: np.ndarray,
    r: np.ndarray,
) -> None:
    """:meth:`DiffDriveRobot.end_step` of every robot (no actuation delay): encoders, odometer, applied command.

    ``half_base`` and ``r``: each robot's half wheel base and wheel radius.
    """
    dx, dy = ends[:, 0] - starts[:, 0], ends[:, 1] - starts[:, 1]
    mid = 0.5 * (starts[:, 2] + ends[:, 2])
    ds = dx * libm(math.cos, mid) + dy * libm(math.sin, mid)
    da = ends[:, 2] - starts[:, 2]
    previous = np.array([robot.encoder_totals for robot in robots], dtype=float).reshape(-1, 2)
    values = np.stack(
        encoder_values(commands[:, 0], commands[:, 1], ds, da, half_base, r, dt, previous[:, 0], previous[:, 1]), axis=1
    )
    distances = map(math.hypot, dx.tolist(), dy.tolist())
    for robot, pose, row, distance in zip(robots, map(tuple, starts[:, :3].tolist()), map(tuple, values.tolist()), distances):
        robot.finish_step(pose, row, distance)
