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
from teamgym.sim.robot import scale_wheel_speeds

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
        self._sensed: dict[int, tuple] = {}  # read_sensors' lists of each world's sensed robots

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_sensed"] = {}  # keyed by the worlds' ids: valid in this process only
        return state

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
        span = [self.copies[k] for k in group]
        if not self._act_rows(rows):
            self._act(group, actions)
        noise = span[0].config.noise_level("motor_noise")
        if noise <= 0:  # BoxPushing._before_physics does nothing
            return
        if len(span) == 1:
            span[0]._before_physics()
            return
        robots, gains = [], []
        for env in span:  # each copy's draws from its own stream, as its _before_physics makes them
            gains.append(env.np_random.normal(1.0, noise, size=(len(env.live_agents), 2)))
            robots += [env.robots[a] for a in env.live_agents]
        scale_wheel_speeds(robots, np.concatenate(gains))

    def after_physics(self, group: list[int]) -> None:
        """Contacts and box gaps, events, success, the team rewards, then the sensors (the order of ``TeamEnv.step``)."""
        copies = self.copies
        team, ks = self._rows(group)
        span = [copies[k] for k in group]
        if len(span) == 1:  # a lone env: no stacking
            poses, cycles = span[0]._box_poses()[None], span[0].cycles
        else:
            poses = np.array([pose for env in span for pose in env._box_pose_rows()])
            poses = poses.reshape(len(span), span[0].box_capacity, 3)
            cycles = np.array([env.cycles for env in span])
        for env in span:
            env._count_contacts()
        team.update_boxes(ks, span[0].goal, poses)
        if span[0].events:
            for env in span:
                env._apply_events()
        team.check_goals(ks, cycles)
        n = len(span[0].possible_agents)
        for env, reward in zip(span, team.rewards(ks).tolist()):
            total = env._reward_total
            if len(env.live_agents) == n:
                total += reward
            else:
                total[env._live_rows()] += reward
        read_sensors([(env, env._going_on()) for env in span], self._sensed)

    def _team_ended(self, group: list[int]) -> np.ndarray | None:
        """The team's success per copy; ``None`` (copy by copy) while a robot leaves (its status is recorded)."""
        team, ks = self._rows(group)
        return None if team.leaving[ks].any() else team.success[ks]

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
        busy = self._busy_rows(span)
        team.observe(ks, first.layout, busy, first.stall_cap, block)
        self._write_rows(group, block, out)

    @staticmethod
    def _busy_rows(span: list[BoxPushing]) -> np.ndarray:
        """``(copies, N)``: :meth:`BoxPushing._busy_rows` of every copy of ``span`` (one array of flags)."""
        n = len(span[0].possible_agents)
        if span[0]._primitives is None or any(len(env.live_agents) != n for env in span):
            return np.stack([env._busy_rows() for env in span])
        flags = [busy for env in span for busy in env._primitives.busy(env.live_agents)]
        rows = np.array([env._row[a] for env in span for a in env.live_agents]).reshape(len(span), n)
        busy = np.zeros((len(span), n))
        np.put_along_axis(busy, rows, np.array(flags, dtype=float).reshape(len(span), n), axis=1)
        return busy
