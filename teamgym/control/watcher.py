"""Task-execution watcher of paper 000, section 2.2 (Fig. 4): a four-state automaton.

The watcher waits for a task (WAITING); a new task switches it to EXECUTING, in which the
behaviour-based controller drives the robot towards the task's waypoints. When the task's
completion test holds it reports to the coordinator and switches to COMPLETED; if an
exception happens (a collision when ``fail_on_collision``, no progress for ``stall_time``,
more than ``timeout`` on the task, or a task-specific check such as a door found closed) it
stops the robot, reports and switches to FAILED. The coordinator reads the report and the
next assignment takes the watcher back through WAITING. A task without waypoints (Wait())
stops the robot and never completes by itself.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from teamgym.control.behaviour import BehaviourController, BehaviourParameters, BehaviourStep

Point = tuple[float, float]


#: Why a task ended: "" (completed, or none yet) and the failure reasons; infos carry the index.
TASK_REASONS = ("", "door closed", "collision", "stalled", "timeout")


class WatcherState(IntEnum):
    """The four states of Fig. 4."""

    WAITING = 0
    EXECUTING = 1
    COMPLETED = 2
    FAILED = 3


@dataclass
class Task:
    """An elementary navigational task sent to the controller.

    ``waypoints`` are visited in order (all but the last are passed within
    ``waypoint_tolerance``); ``is_done(x, y)`` is the completion test (None: never, as for
    Wait()); ``check(x, y)`` may return the reason of a task-specific exception or None.
    """

    name: str
    waypoints: tuple[Point, ...]
    is_done: Callable[[float, float], bool] | None
    params: BehaviourParameters = field(default_factory=BehaviourParameters)
    check: Callable[[float, float], str | None] | None = None
    waypoint_tolerance: float = 0.02
    key: int = -1

    @property
    def is_wait(self) -> bool:
        return not self.waypoints


@dataclass
class TaskReport:
    """What the watcher sends to the coordinator when a task ends (or is still running)."""

    task: str
    status: WatcherState
    reason: str = ""
    duration: float = 0.0
    straight: float = 0.0
    travelled: float = 0.0
    start: Point = (0.0, 0.0)


class TaskWatcher:
    """Runs one task at a time on a :class:`BehaviourController` and watches its execution."""

    def __init__(
        self, stall_time: float = 5.0, timeout: float = 60.0, fail_on_collision: bool = False, min_progress: float = 0.01
    ) -> None:
        if not (stall_time > 0 and timeout > 0 and min_progress > 0):
            raise ValueError("stall_time, timeout and min_progress must be > 0")
        self.stall_time = float(stall_time)
        self.timeout = float(timeout)
        self.fail_on_collision = bool(fail_on_collision)
        self.min_progress = float(min_progress)
        self.state = WatcherState.WAITING
        self.task: Task | None = None
        self.report: TaskReport | None = None
        self.controller = BehaviourController()
        self.last_step: BehaviourStep | None = None
        self._waypoint = 0
        self._start_time = 0.0
        self._start_odometer = 0.0
        self._start = (0.0, 0.0)
        self._best = math.inf
        self._best_time = 0.0

    # -- coordinator side ---------------------------------------------------------------
    def assign(self, task: Task, time: float, position: Point, odometer: float) -> None:
        """Start ``task`` now (WAITING → EXECUTING; a running task is replaced)."""
        self.state = WatcherState.EXECUTING
        self.task = task
        self.report = None
        self.controller = BehaviourController(task.params)
        self._waypoint = 0
        self._start_time = time
        self._start_odometer = odometer
        self._start = (float(position[0]), float(position[1]))
        self._best = math.inf
        self._best_time = time

    @property
    def executing(self) -> bool:
        return self.state == WatcherState.EXECUTING

    @property
    def target(self) -> Point | None:
        if self.task is None or self.task.is_wait or self.state != WatcherState.EXECUTING:
            return None
        return self.task.waypoints[min(self._waypoint, len(self.task.waypoints) - 1)]

    # -- robot side ------------------------------------------------------------------
    def control(self, pose: tuple[float, float, float], proximity: np.ndarray, collided: bool = False) -> tuple[float, float]:
        """The command (v, ω) for this control step (zero unless EXECUTING)."""
        if self.state != WatcherState.EXECUTING or self.task is None:
            self.last_step = None
            return 0.0, 0.0
        target = self._current_target(pose)
        self.last_step = self.controller.step(pose, proximity, target, collided=collided)
        return self.last_step.command

    def _current_target(self, pose: tuple[float, float, float]) -> Point | None:
        task = self.task
        if task is None or task.is_wait:
            return None
        while self._waypoint < len(task.waypoints) - 1:
            wx, wy = task.waypoints[self._waypoint]
            if math.hypot(wx - pose[0], wy - pose[1]) > task.waypoint_tolerance:
                break
            self._waypoint += 1
            self._best = math.inf
        return task.waypoints[self._waypoint]

    def after_step(self, time: float, position: Point, odometer: float, collided: bool = False) -> WatcherState:
        """Update the automaton after the physics step; returns the (possibly new) state."""
        if self.state != WatcherState.EXECUTING or self.task is None:
            return self.state
        task = self.task
        x, y = float(position[0]), float(position[1])
        if task.is_done is not None and task.is_done(x, y):
            return self._finish(WatcherState.COMPLETED, "", time, position, odometer)
        reason = task.check(x, y) if task.check is not None else None
        if reason is None and collided and self.fail_on_collision:
            reason = "collision"
        if reason is None and not task.is_wait:
            target = task.waypoints[self._waypoint]
            distance = math.hypot(target[0] - x, target[1] - y)
            if distance < self._best - self.min_progress:
                self._best, self._best_time = distance, time
            elif time - self._best_time > self.stall_time:
                reason = "stalled"
            if time - self._start_time > self.timeout:
                reason = "timeout"
        if reason is not None:
            return self._finish(WatcherState.FAILED, reason, time, position, odometer)
        return self.state

    def _finish(self, state: WatcherState, reason: str, time: float, position: Point, odometer: float) -> WatcherState:
        self.state = state
        self.report = TaskReport(
            task=self.task.name if self.task else "",
            status=state,
            reason=reason,
            duration=time - self._start_time,
            straight=math.hypot(position[0] - self._start[0], position[1] - self._start[1]),
            travelled=odometer - self._start_odometer,
            start=self._start,
        )
        return state

    def acknowledge(self) -> None:
        """The coordinator has read the report: COMPLETED/FAILED → WAITING."""
        if self.state in (WatcherState.COMPLETED, WatcherState.FAILED):
            self.state = WatcherState.WAITING
