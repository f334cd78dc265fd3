"""Navigation's control-step phases over copies whose per-step arrays share one :class:`NavigationArrays`.

A lone :class:`~teamgym.envs.navigation.env.Navigation` env runs them over its own row; a
:class:`~teamgym.envs.batch.TeamBatch` of Navigation copies binds every copy to one row of a
shared ``NavigationArrays`` (:meth:`NavigationPhases.regroup`) and runs each phase once for all of
them: commands, poses, distances, contacts, progress, arrivals, rewards, sensing and
observations are one numpy pass over the copies; the worlds step one after the other.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.envs.navigation.state import NavigationArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases

if TYPE_CHECKING:
    from teamgym.envs.navigation.env import Navigation

__all__ = ["NavigationPhases"]


class NavigationPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for Navigation copies, over their ``NavigationArrays`` rows."""

    copies: list[Navigation]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start

    def __init__(self, copies: list[Navigation]) -> None:
        super().__init__(copies)
        self._shared: NavigationArrays | None = None  # a batch's (made by regroup)
        self._live = np.zeros((0, 0), dtype=bool)
        self._arriving = np.zeros((0, 0), dtype=bool)

    def regroup(self) -> None:
        """Bind copy ``k`` to row ``k`` of one shared ``NavigationArrays`` (its rows so far are copied in)."""
        copies = self.copies
        first = copies[0]
        if self._shared is None:
            self._shared = NavigationArrays(first.config, 0, first.ring.width)
        team = self._shared
        team.shrink(len(copies))
        team.grow(len(copies))
        for k, env in enumerate(copies):
            if env._arrays is team and env._copy == k:
                continue
            team.set_row(k, env._arrays.row(env._copy))
            env._use_rows(team, k)

    def _rows(self, group: list[int]) -> tuple[NavigationArrays, slice]:
        """The team and the slice of its rows that covers ``group`` (copies bind to consecutive rows)."""
        copies = self.copies
        return copies[group[0]]._arrays, slice(copies[group[0]]._copy, copies[group[-1]]._copy + 1)

    def _span_live_mask(self, group: list[int], ks: slice) -> np.ndarray:
        """``(len(ks), N)``: the live robots of the copies of ``group`` (rows of the other copies of the span False)."""
        if len(self.copies) == 1:
            return self.copies[0]._live_mask()
        if len(group) == ks.stop - ks.start:  # the span is the group
            return self._live_mask(group)
        live = np.zeros((ks.stop - ks.start, self.copies[0].config.n_robots), dtype=bool)
        for k in group:
            live[k - group[0], self.copies[k]._live_rows()] = True
        return live

    def control(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        """Commands of the acting robots (the action type's vectorised ``commands`` when the batch has arrays), then delays."""
        copies = self.copies
        team, ks = self._rows(group)
        if not self._act_rows(rows):
            self._act(group, actions)
        self._live = live = self._span_live_mask(group, ks)
        span = self._span(group, ks)
        team.command(ks, live, np.array([[robot.command for robot in env.robot_list] for env in span], dtype=float))
        if span[0].config.actuation_delay > 0:
            for k in group:
                env = copies[k]
                env._delay_actuation(env.robot_list, env.np_random)

    def after_physics(self, group: list[int]) -> None:
        """Poses, distances, contacts, progress, smoothness (section 6.2), arrivals, rewards, then the rings."""
        copies = self.copies
        team, ks = self._rows(group)
        span = self._span(group, ks)
        together = self._group_robot_states(group) if len(span) == len(group) > 1 else None
        robots, movers = [], []
        for env in span:
            world = env.world
            if together is None and len(world.robot_states) != len(env.robot_list):
                world.read_states()
            robots.append(world.robot_states)
            movers.append(world.mover_states)
        names, dt = span[0].possible_agents, span[0].config.dt
        if len(span) == 1:  # a lone env: no stacking
            poses = robots[0][None]
            team.read(ks, poses, movers[0][None])
            hits = span[0].world.contacts_per(names)[None]
            times: np.ndarray | float = span[0].cycles * dt
        else:
            poses = np.stack(robots) if together is None else together
            team.read(ks, poses, np.stack(movers))
            hits = np.zeros((len(span), len(names)), dtype=np.int64)
            for j, env in enumerate(span):
                if env.world.contacts:  # else every count is 0
                    hits[j] = env.world.contacts_per(names)
            times = np.array([env.cycles for env in span]) * dt
        team.update_distances(ks)
        live = self._live
        team.after_physics(ks, live, hits)
        arriving = team.check_goals(ks, live, times)
        rewards = team.rewards(ks, live)
        for k in group:
            copies[k]._reward_total += rewards[k - group[0]]
        self._sense(group, team, ks, span, live & ~arriving, poses)

    def _span(self, group: list[int], ks: slice) -> list[Navigation]:
        """The copies bound to rows ``ks`` (``group`` and the copies between its first and last)."""
        return self.copies[group[0] : group[0] + ks.stop - ks.start]

    def _sense(
        self, group: list[int], team: NavigationArrays, ks: slice, span: list[Navigation], sensing: np.ndarray, poses: np.ndarray
    ) -> None:
        """Proximity rings of the ``sensing`` robots: rays only where something is within range.

        A noiseless ring with nothing near reads ``sensor_range`` in one numpy step; the other
        rows read through their copy (which casts the rays and draws the noise), or, with a
        noiseless ring, every copy's rows in one pass. ``poses``: ``(copies, N, 6)`` robot states.
        """
        if len(span) == 1:  # a lone env: the ring's own reach check costs less than the arrays' (the same readings)
            span[0]._read_proximity(np.flatnonzero(sensing[0]))
            return
        free = team.sensing_free(ks)
        ring = span[0].ring
        if ring.noiseless:
            clear = sensing & free
            team.proximity[ks][clear] = ring.max_range
            sensing = sensing & ~free
            if len(span) > 1:  # every copy's remaining rings in one pass (ProximityRing.read_many)
                self._read_rings(team, ks, span, sensing, poses)
                return
        for j in np.flatnonzero(sensing.any(axis=1)).tolist():
            rows = np.flatnonzero(sensing[j])
            span[j]._read_proximity(rows, free[j, rows])

    @staticmethod
    def _read_rings(team: NavigationArrays, ks: slice, span: list[Navigation], sensing: np.ndarray, poses: np.ndarray) -> None:
        """Noiseless rings of the ``sensing`` robots of every copy of ``span`` at once, as each copy would read them."""
        copy_rows, robot_rows = np.nonzero(sensing)
        if len(copy_rows) == 0:
            return
        pairs = list(zip(copy_rows.tolist(), robot_rows.tolist()))
        ring = span[0].ring
        block = np.empty((len(pairs), ring.width), dtype=np.float32)
        robots = [span[j].robot_list[i] for j, i in pairs]
        ring.read_many([span[j].world.space for j, _ in pairs], robots, poses[copy_rows, robot_rows], block)
        team.proximity[ks][copy_rows, robot_rows] = block

    def end(self, group: list[int], rewards: np.ndarray, terminated: np.ndarray, truncated: np.ndarray) -> None:
        """The end phase as arrays (as :meth:`TeamEnv._end_step` per copy): arrivals terminate, the cycle limit truncates."""
        copies = self.copies
        if copies[group[0]].action_type.has_masks or any(copies[k]._joining for k in group):
            super().end(group, rewards, terminated, truncated)
            return
        team, ks = self._rows(group)
        span = self._span(group, ks)
        for k in group:
            copies[k]._deliver_messages()
        live = self._live
        rows = slice(group[0], group[0] + len(span))
        np.copyto(rewards[rows], np.stack([env._reward_total for env in span]), where=live)
        arrived = team.arrived[ks] & live
        terminated[rows] = arrived
        limit = span[0].config.cycle_limit
        truncated[rows] = live & ~arrived & (np.array([env.cycles for env in span]) >= limit)[:, None]

    def observe(self, group: list[int], out: np.ndarray) -> None:
        """Every robot row of the copies ``group`` in one pass; rows of robots not live are zeroed."""
        team, ks = self._rows(group)
        first = group[0]
        block = out[first : first + ks.stop - ks.start]
        span = self._span(group, ks)
        layout = span[0].layout
        team.observe(ks, layout, block)
        live = np.zeros(block.shape[:2], dtype=bool)
        for j, env in enumerate(span):
            rows = env._live_rows()
            live[j, rows] = True
            if env.config.comm_dim and len(rows):
                inbox = block[j, rows]
                env._observe_inbox(inbox)
                block[j, rows] = inbox
        layout.clip(block)
        block[~live] = 0.0
