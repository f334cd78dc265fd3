"""``BoxPushingArrays``: BoxPushing's per-episode state for K env copies, as arrays over copies.

Every array has a leading copy axis ``k``; robot arrays then a row per possible robot
(``possible_agents`` order), box arrays a slot per box (``box_capacity``). A single
:class:`~teamgym.envs.box_pushing.env.BoxPushing` env is the case K = 1 (row 0 of its own
arrays); a :class:`~teamgym.envs.batch.TeamBatch` of BoxPushing copies binds copy ``k`` to
row ``k`` of one shared ``BoxPushingArrays``
(:class:`~teamgym.envs.box_pushing.phases.BoxPushingPhases`), which computes box gaps,
deliveries, success, rewards and observations for all copies in one numpy pass. Besides
these arrays an episode holds only its simulated objects (the world, its robots and boxes),
the sensors' per-robot calibrations and the primitive executors of its action type.

Methods take ``ks``, a ``slice`` of copies (views, so writes land in the shared arrays).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from teamgym.envs.copy_arrays import CopyArrays

if TYPE_CHECKING:
    from teamgym.envs.box_pushing.config import BoxPushingConfig
    from teamgym.envs.box_pushing.scene import GoalWall
    from teamgym.envs.spaces import ObservationLayout

__all__ = ["LEAVING", "BoxPushingArrays"]

#: Codes of ``status`` / ``leaving``: why a robot left its episode (0: it did not).
LEAVING = {"removed": 1, "broken_down": 2}

#: Box slots below which a copy's progress (a sum over its boxes) is summed over all slots at
#: once: numpy sums fewer than 8 values one after the other, so absent slots (zeros) change no bit.
_SEQUENTIAL_SUM = 8


class BoxPushingArrays(CopyArrays):
    """Robot readings and counters, box slots and team clocks of ``n_copies`` BoxPushing copies."""

    def __init__(
        self,
        config: BoxPushingConfig,
        n_robots: int,
        box_capacity: int,
        width: int,
        n_events: int,
        light_width: int,
        n_copies: int = 1,
    ) -> None:
        self.config = config
        self.n_robots, self.box_capacity, self.width, self.n_events = n_robots, box_capacity, width, n_events
        self.light_width = light_width
        self.n_copies = 0
        self.grow(n_copies)

    # -- storage ---------------------------------------------------------------------
    def _allocate(self, k: int) -> dict[str, np.ndarray]:
        n, b = self.n_robots, self.box_capacity
        return {
            # robots (k, N): sensor readings (the suite's columns), counters and why they left
            "readings": np.zeros((k, n, self.width), dtype=np.float32),
            "light_gains": np.ones((k, n, self.light_width)),  # each light sensor's sensitivity (``gain_spread``)
            "collisions": np.zeros((k, n), dtype=int),
            "stalled": np.zeros((k, n), dtype=int),
            "stall_run": np.zeros((k, n), dtype=int),
            "status": np.zeros((k, n), dtype=np.int8),
            "leaving": np.zeros((k, n), dtype=np.int8),
            # box slots (k, B)
            "box_present": np.zeros((k, b), dtype=bool),
            "box_heavy": np.zeros((k, b), dtype=bool),
            "box_half": np.zeros((k, b)),
            "box_gap": np.zeros((k, b)),
            "box_delivered": np.zeros((k, b), dtype=bool),
            # the team (k,): slots and spares used, progress, success and its time, events applied
            "n_boxes": np.zeros(k, dtype=int),
            "robots_used": np.zeros(k, dtype=int),
            "progress": np.zeros(k),
            "step_progress": np.zeros(k),
            "success": np.zeros(k, dtype=bool),
            "new_success": np.zeros(k, dtype=bool),
            "success_time": np.full(k, np.nan),
            "next_event": np.zeros(k, dtype=int),
            # scheduled events (k, E) that could not be applied (robot already gone, table full)
            "event_skipped": np.zeros((k, self.n_events), dtype=bool),
        }

    def start(self, k: int, proximity: slice) -> None:
        """A new episode in copy ``k``: no box, no robot placed, counters cleared; rings read free."""
        self.clear_row(k)
        self.readings[k, :, proximity] = self.config.sensor_range

    # -- phases ----------------------------------------------------------------------
    def update_boxes(self, ks: slice | np.ndarray, goal: GoalWall, poses: np.ndarray, accumulate: bool = True) -> None:
        """Gaps of the boxes (poses ``(k, B, 3)``, rows of absent slots ignored) to the goal wall; deliveries; progress.

        ``ks``: a slice of copies or their indices. ``step_progress`` is this control step's
        decrease of the gaps summed over the boxes on the table (m); ``progress`` accumulates it
        (unless ``accumulate`` is false: boxes were moved by hand and are measured anew).
        """
        present = self.box_present[ks]
        gaps = goal.gaps(poses, self.box_half[ks])
        gap = self.box_gap[ks]
        if self.box_capacity < _SEQUENTIAL_SUM:
            step = np.where(present, gap - gaps, 0.0).sum(axis=1)
        else:
            step = np.array([float(np.sum((gap[j] - gaps[j])[present[j]])) for j in range(len(gap))])
        self.step_progress[ks] = step
        if accumulate:
            self.progress[ks] += step
        self.box_gap[ks] = np.where(present, gaps, gap)
        self.box_delivered[ks] |= present & (gaps <= self.config.goal_tolerance)

    def check_goals(self, ks: slice | np.ndarray, cycles: np.ndarray | int) -> None:
        """Success of copies whose ``boxes_to_goal`` boxes (0: every box on the table) have been delivered (at ``cycles``)."""
        delivered = self.box_delivered[ks]
        if not delivered.any():  # the usual case: nothing delivered, no success
            self.new_success[ks] = False
            return
        present = self.box_present[ks]
        on_table = present.sum(axis=1)
        target = self.config.boxes_to_goal or on_table
        reached = (on_table > 0) & ((delivered & present).sum(axis=1) >= target)
        new = reached & ~self.success[ks]
        self.new_success[ks] = new
        if new.any():
            self.success[ks] |= new
            self.success_time[ks] = np.where(new, cycles * self.config.dt, self.success_time[ks])

    def rewards(self, ks: slice | np.ndarray) -> np.ndarray:
        """``(k,)``: the team's reward of this control step, shared by every live robot of a copy."""
        c = self.config
        return c.progress_reward * self.step_progress[ks] - c.time_penalty + np.where(self.new_success[ks], c.success_bonus, 0.0)

    # -- observations ----------------------------------------------------------------
    def observe(self, ks: slice, layout: ObservationLayout, busy: np.ndarray, stall_cap: int, out: np.ndarray) -> None:
        """Every robot row's flat observation (readings, ``busy``, ``stall``) into ``out`` (k, N, D)."""
        s = self.width
        out[..., :s] = self.readings[ks]
        slices = layout.slices
        out[..., slices["busy"].start] = busy
        if "stall" in slices:
            out[..., slices["stall"].start] = np.minimum(self.stall_run[ks], stall_cap) / stall_cap
