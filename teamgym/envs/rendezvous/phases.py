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

import numpy as np

from teamgym.envs.rendezvous.state import RendezvousArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases

if TYPE_CHECKING:
    from teamgym.envs.rendezvous.config import RendezvousConfig
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
        self._bind_to_shared_rows(self._shared)

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
        """Each copy's arrivals, give-ups, contacts and events; then goals, rewards and sensing over the group.

        A lone env (a group of one) runs its own hooks: one copy gains nothing from arrays.
        """
        copies = self.copies
        first = copies[group[0]]
        c = first.config
        events = bool(c.blockings) or c.block_rate > 0
        if len(group) == 1:
            first._update_state()
            if events:
                first._apply_events()
            first._check_goals()
            first._accumulate_rewards(first._reward_total)
            first._sense()
            return
        span = [copies[k] for k in group]
        for env in span:
            env._update_state()
            if events:
                env._apply_events()
        team = first._arrays
        rows = np.array([env._copy for env in span])
        times = np.array([env.world.time for env in span])
        distances, mean = pair_distances(np.stack([env.world.robot_states[:, :2] for env in span]))
        self._check_goals(team, rows, distances, times, c.meet_distance)
        rewards = self._rewards(c, team, rows, mean, times)
        for env, reward in zip(span, rewards):
            env._reward_total += reward
        if first.ring.noiseless:
            team.rings_due[rows] = True
        else:
            for env in span:
                env._read_rings()
        for env in span:
            if team.blocked_order[env._copy]:
                env._detect_blocked()

    @staticmethod
    def _check_goals(team: RendezvousArrays, rows: np.ndarray, distances: np.ndarray, times: np.ndarray, meet: float) -> None:
        """Copies whose robots are all within ``meet`` of each other meet now (as ``Rendezvous._check_goals``)."""
        meeting = ~team.met[rows] & (distances <= meet).all(axis=(1, 2))
        if meeting.any():
            team.met[rows[meeting]] = True
            team.meeting_time[rows[meeting]] = times[meeting]

    @staticmethod
    def _rewards(
        c: RendezvousConfig, team: RendezvousArrays, rows: np.ndarray, mean: np.ndarray, times: np.ndarray
    ) -> np.ndarray:
        """``(g, N)``: this control step's rewards (:meth:`Rendezvous._accumulate_rewards`, the same operations)."""
        reward = c.progress_reward * (team.distance[rows] - mean) - c.time_penalty
        team.distance[rows] = mean
        bonus = team.met[rows] & (team.meeting_time[rows] == times)
        if bonus.any():
            reward = np.where(bonus, reward + c.meet_bonus, reward)
        # Without contacts in the last step the counts are 0, and ``r − p · 0`` is what the lone env adds then.
        return reward[:, None] - c.collision_penalty * team.new_contacts[rows]


def pair_distances(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre distances ``(g, n, n)`` of every copy's robots at ``points`` ``(g, n, 2)`` and their means ``(g,)``.

    The operations of :meth:`Rendezvous._pair_distances <teamgym.envs.rendezvous.env.Rendezvous._pair_distances>`
    (``√((xi − xj)² + (yi − yj)²)``; for two robots the mean is their one distance; else the sum of
    each copy's ``n × n`` block over ``n (n − 1)``, summed block by block as the lone env sums it).
    """
    dx = points[:, :, None, 0] - points[:, None, :, 0]
    dy = points[:, :, None, 1] - points[:, None, :, 1]
    distances = np.sqrt(dx * dx + dy * dy)
    n = points.shape[1]
    if n == 2:
        return distances, distances[:, 0, 1].copy()
    return distances, np.array([block.sum() / (n * (n - 1)) for block in distances])
