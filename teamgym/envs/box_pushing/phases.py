"""BoxPushing's control-step phases over copies whose episode state shares one :class:`BoxPushingArrays`.

A lone :class:`~teamgym.envs.box_pushing.env.BoxPushing` env runs them over its own row; a
:class:`~teamgym.envs.batch.TeamBatch` of BoxPushing copies binds every copy to one row of a
shared ``BoxPushingArrays`` (:meth:`BoxPushingPhases.regroup`) and runs each phase once for
all of them: wheel commands, box gaps, deliveries, progress, success, the shared rewards and
the observations are one numpy pass over the copies; the worlds step, the sensors read and
the primitive executors run copy after copy (they query each copy's own pymunk space).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.envs.box_pushing.sensing import read_sensors
from teamgym.envs.box_pushing.state import BoxPushingArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases

if TYPE_CHECKING:
    from teamgym.envs.box_pushing.env import BoxPushing

__all__ = ["BoxPushingPhases"]


class BoxPushingPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for BoxPushing copies, over their ``BoxPushingArrays`` rows."""

    copies: list[BoxPushing]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start

    def __init__(self, copies: list[BoxPushing]) -> None:
        super().__init__(copies)
        self._shared: BoxPushingArrays | None = None  # a batch's (made by regroup)

    def regroup(self) -> None:
        """Bind copy ``k`` to row ``k`` of one shared ``BoxPushingArrays`` (its rows so far are copied in)."""
        copies = self.copies
        if self._shared is None:
            own = copies[0]._arrays
            self._shared = BoxPushingArrays(
                own.config, own.n_robots, own.box_capacity, own.width, own.n_events, own.light_width, n_copies=0
            )
        self._bind_to_shared_rows(self._shared)

    def control(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        """Commands of the acting robots (the action type's vectorised ``commands`` when the batch has arrays), motor noise."""
        if not self._act_rows(rows):
            self._act(group, actions)
        for k in group:
            self.copies[k]._before_physics()

    def after_physics(self, group: list[int]) -> None:
        """Contacts and box gaps, events, success, the team rewards, then the sensors (the order of ``TeamEnv.step``)."""
        copies = self.copies
        team, ks = self._rows(group)
        span = [copies[k] for k in group]
        if len(span) == 1:  # a lone env: no stacking
            poses, cycles = span[0]._box_poses()[None], span[0].cycles
        else:
            poses, cycles = np.stack([env._box_poses() for env in span]), np.array([env.cycles for env in span])
        for env in span:
            env._count_contacts()
        team.update_boxes(ks, span[0].goal, poses)
        if span[0].events:
            for env in span:
                env._apply_events()
        team.check_goals(ks, cycles)
        for env, reward in zip(span, team.rewards(ks).tolist()):
            env._reward_total[env._live_rows()] += reward
        read_sensors([(env, env._going_on()) for env in span])

    def observe(self, group: list[int], out: np.ndarray) -> None:
        """Every robot row of the copies ``group`` in one pass; rows of robots not live are zeroed."""
        if len(group) == 1:  # one copy: its own rows (the lone env's path) cost less than the pass
            super().observe(group, out)
            return
        copies = self.copies
        team, ks = self._rows(group)
        span = [copies[k] for k in group]
        first = span[0]
        block = np.empty((len(group), *out.shape[1:]), dtype=out.dtype)
        busy = np.stack([env._busy_rows() for env in span])
        team.observe(ks, first.layout, busy, first.stall_cap, block)
        live = np.zeros(block.shape[:2], dtype=bool)
        for j, env in enumerate(span):
            rows = env._live_rows()
            live[j, rows] = True
            if env.config.comm_dim and len(rows):
                inbox = block[j, rows]
                env._observe_inbox(inbox)
                block[j, rows] = inbox
        first.layout.clip(block)
        block[~live] = 0.0
        out[group] = block
