"""Rendezvous's control-step phases over copies whose episode state shares one :class:`RendezvousArrays`.

A lone :class:`~teamgym.envs.rendezvous.env.Rendezvous` env runs them over its own row; a
:class:`~teamgym.envs.batch.TeamBatch` of Rendezvous copies binds every copy to one row of a
shared ``RendezvousArrays`` (:meth:`RendezvousPhases.regroup`). The way-following controllers
(:meth:`NextPlaceAction.drive <teamgym.envs.rendezvous.actions.NextPlaceAction.drive>`) set
every acting robot's command copy by copy; the worlds step one after the other, each taking its
last read of the bodies as the start of its next step (nothing moves a body between steps);
then each copy's arrivals, give-ups and contacts, and goals, rewards and sensing in one numpy
pass over the group.

The controllers and the arrival checks use ``math`` (``hypot``, ``atan2``, ``remainder``): numpy's
vectorised forms of those functions are not always bit-identical with them (its SIMD
``arctan2`` and ``hypot`` differ in the last bit for some inputs), and the lone env's trajectories
must not change. The goals and rewards use only ``+ − × ÷ √`` and comparisons, which numpy
rounds as Python does, so they run over the copies at once.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from teamgym.envs.rendezvous.state import RendezvousArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases

if TYPE_CHECKING:
    from teamgym.envs.rendezvous.env import Rendezvous

__all__ = ["RendezvousPhases"]


class RendezvousPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for Rendezvous copies, over their ``RendezvousArrays`` rows."""

    copies: list[Rendezvous]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start

    def __init__(self, copies: list[Rendezvous]) -> None:
        super().__init__(copies)
        self._shared: RendezvousArrays | None = None  # a batch's (made by regroup)

    def regroup(self) -> None:
        """Bind copy ``k`` to row ``k`` of one shared ``RendezvousArrays`` (its rows so far are copied in)."""
        copies = self.copies
        if self._shared is None:
            self._shared = RendezvousArrays(*copies[0]._arrays.shape, copies[0]._arrays.sensor_range, 0)
        team = self._shared
        team.shrink(len(copies))
        team.grow(len(copies))
        for k, env in enumerate(copies):
            if env._arrays is team and env._copy == k:
                continue
            team.set_row(k, env._arrays.row(env._copy))
            env._use_rows(team, k)

    def control(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        """The acting robots' commands: the way-following controllers of ``next_place``, else the action type's ``act``.

        Rendezvous has no ``_before_physics`` (no actuation delay), so that hook is not called.
        """
        copies = self.copies
        motion = copies[group[0]].next_place
        if motion is None:
            super().control(group, actions, rows)
            return
        for k, joint in zip(group, actions):
            motion.drive(copies[k], joint)

    def after_physics(self, group: list[int]) -> None:
        """Each copy's arrivals, give-ups, contacts and events; then goals, rewards and sensing over the group."""
        copies = self.copies
        first = copies[group[0]]
        events = bool(first.config.blockings) or first.config.block_rate > 0
        for k in group:
            env = copies[k]
            env._update_state()
            if events:
                env._apply_events()
            env._check_goals()
            env._accumulate_rewards(env._reward_total)
            env._sense()
