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

from teamgym.envs.rendezvous.group import FollowerRows, arrived, way_commands
from teamgym.envs.rendezvous.state import RendezvousArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases
from teamgym.sim.robot import set_commands

if TYPE_CHECKING:
    from teamgym.envs.rendezvous.config import RendezvousConfig
    from teamgym.envs.rendezvous.env import Rendezvous

__all__ = ["RendezvousPhases"]


class RendezvousPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for Rendezvous copies, over their ``RendezvousArrays`` rows."""

    copies: list[Rendezvous]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start
    #: Copies from which a group is driven and checked in one pass (:mod:`teamgym.envs.rendezvous.group`): below
    #: it, each copy's scalar controllers cost less than the passes' fixed cost (measured 2026-12-07).
    min_group = 16

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
        """The acting robots' commands: the way-following controllers of ``next_place`` (every robot of a group's
        copies in one pass, :func:`~teamgym.envs.rendezvous.group.way_commands`), else the action type's ``act``.

        Rendezvous has no ``_before_physics`` (no actuation delay), so that hook is not called.
        """
        copies = self.copies
        first = copies[group[0]]
        motion = first.next_place
        if motion is None:
            super().control(group, actions, rows)
            return
        n = first.config.n_robots
        if len(group) < self.min_group or any(len(joint) != n for joint in actions):
            for k, joint in zip(group, actions):
                motion.drive(copies[k], joint)
            return
        team, ks = self._rows(group)
        span = [copies[k] for k in group]
        poses = np.stack([env.world.robot_states[:, :3] for env in span])
        commands = way_commands(self._followers(first), poses, team.origin[ks], team.target[ks], first.places_xy)
        set_commands([robot for env in span for robot in env.robot_list], commands.reshape(-1, 2))

    def _followers(self, first: Rendezvous) -> FollowerRows:
        """The way followers' parameters per robot row and the move time-outs per (robot, from, to), made once."""
        memo = self.__dict__.get("_follower_rows")
        if memo is None or memo[0] is not first.followers:
            rows = FollowerRows(first.followers, first.move_timeouts, len(first.places))
            memo = self._follower_rows = (first.followers, rows)
        return memo[1]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_follower_rows", None)
        return state

    def after_physics(self, group: list[int]) -> None:
        """Each copy's arrivals, give-ups, contacts and events; then goals, rewards and sensing over the group.

        A group smaller than ``min_group`` (a lone env too) runs each copy's own hooks.
        """
        if len(group) < self.min_group:
            super().after_physics(group)
            return
        copies = self.copies
        first = copies[group[0]]
        c = first.config
        events = bool(c.blockings) or c.block_rate > 0
        span = [copies[k] for k in group]
        team = first._arrays
        rows = np.array([env._copy for env in span])
        times = np.array([env.world.time for env in span])
        points = np.stack([env.world.robot_states[:, :3] for env in span])
        self._update_states(span, team, rows, points, times)
        if events:
            for env in span:
                env._apply_events()
        distances, mean = pair_distances(points[..., :2])
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

    def _update_states(
        self, span: list[Rendezvous], team: RendezvousArrays, rows: np.ndarray, poses: np.ndarray, times: np.ndarray
    ) -> None:
        """``Rendezvous._update_state`` of every copy: arrivals and time-outs found in one pass, then handled copy by
        copy in robot order (places of standing robots, arrivals, give-ups), then contacts and waiting blockers."""
        first = span[0]
        followers = self._followers(first)
        team.arrived_now[rows] = False
        target, origin = team.target[rows], team.origin[rows]
        moving = target >= 0
        arrive = arrived(followers, poses, target, first.places_xy)
        robot = np.arange(target.shape[1])
        late = moving & ~arrive
        if late.any():
            limit = followers.timeouts[robot, np.maximum(origin, 0), np.maximum(target, 0)]
            late &= times[:, None] - team.move_start[rows] > limit
        busy = ~moving | arrive | late
        for j in np.flatnonzero(busy.any(axis=1)).tolist():
            env, k = span[j], int(rows[j])
            place, poses_j = team.place[k], None
            for i in np.flatnonzero(busy[j]).tolist():
                if not moving[j, i]:
                    if poses_j is None:
                        poses_j = env._poses()
                    place[i] = env._nearest_place(i, poses_j[i])
                elif arrive[j, i]:
                    goal = int(target[j, i])
                    place[i], team.target[k, i] = goal, -1
                    team.arrived_now[k, i] = True
                    env._on_arrival(goal)
                else:
                    env._abandon_move(i)
        for env in span:
            env._note_contacts()

    def going_on(self, group: list[int]) -> list[int]:
        """Copies whose stage goes on (``NextPlaceAction.stage_over`` over the group's rows, and the cycle limit)."""
        copies = self.copies
        first = copies[group[0]]
        if first.next_place is None or len(group) < self.min_group:
            return super().going_on(group)
        team, rows = self._rows(group)
        over = team.met[rows] | (team.target[rows] < 0).all(axis=1)
        if first.next_place.stage_end == "any":
            over |= team.arrived_now[rows].any(axis=1)
        limit = first.config.cycle_limit
        return [i for i, (done, k) in enumerate(zip(over.tolist(), group)) if not done and copies[k].cycles < limit]

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

    def _team_ended(self, group: list[int]) -> np.ndarray:
        """The robots met, per copy (``Rendezvous._terminations``)."""
        team, ks = self._rows(group)
        return team.met[ks]
