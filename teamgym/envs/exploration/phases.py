"""Exploration's control-step phases over copies whose episode state shares one :class:`ExplorationArrays`.

A lone :class:`~teamgym.envs.exploration.env.Exploration` env runs them over its own row (its
own hooks: one copy gains nothing from arrays); a :class:`~teamgym.envs.batch.TeamBatch` of
Exploration copies binds every copy to one row of a shared ``ExplorationArrays``
(:meth:`ExplorationPhases.regroup`) and runs each phase once for all of them: velocity
commands from the batch's action rows, then after the worlds have stepped (copy after copy,
each taking its last read of the bodies as the start of its next step) sectors, door
sightings, places, the explored set, explore times and the team rewards in one numpy pass,
and the observations in another. Contacts, ray casts and the operator watchers run copy by
copy (they query each copy's own pymunk space or Python controllers).

The observation's heading ``remainder(θ, 2π)`` and forward speed ``vx cos θ + vy sin θ`` take
``math``'s bits (:mod:`teamgym.sim.libm`): numpy's ``remainder`` is a floored modulo and its SIMD
``cos``/``sin`` may differ from ``math``'s in the last bit. Everything else uses comparisons and ``+ − × √``,
which numpy rounds as Python does.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.control.watcher import WatcherState
from teamgym.envs.base import TeamEnv
from teamgym.envs.exploration.state import ExplorationArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases
from teamgym.sim.libm import libm, remainder_tau

if TYPE_CHECKING:
    from teamgym.envs.exploration.env import Exploration

__all__ = ["ExplorationPhases"]


class ExplorationPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for Exploration copies, over their ``ExplorationArrays`` rows."""

    copies: list[Exploration]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start

    def __init__(self, copies: list[Exploration]) -> None:
        super().__init__(copies)
        self._shared: ExplorationArrays | None = None  # a batch's (made by regroup)

    def regroup(self) -> None:
        """Bind copy ``k`` to row ``k`` of one shared ``ExplorationArrays`` (its rows so far are copied in).

        Every copy rebinds, also one already at its row: growing the arrays replaced them, and the
        copy's model and clutter estimate hold views of its row.
        """
        if self._shared is None:
            own = self.copies[0]._arrays
            self._shared = ExplorationArrays(
                own.n_robots, own.ring_width, own.sensor_range, own.clutter_prior, own.door_prior, n_copies=0
            )
        self._bind_to_shared_rows(self._shared)
        for k, env in enumerate(self.copies):  # growing replaced the arrays: the model's views follow
            env._use_rows(self._shared, k)

    def control(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        """Commands of the acting robots (the action type's vectorised ``commands`` when the batch has arrays);
        door re-sampling (``_before_physics``) only when ``door_resample_period`` is set."""
        if not self._act_rows(rows):
            self._act(group, actions)
        if self.copies[group[0]].config.door_resample_period > 0:
            for k in group:
                self.copies[k]._before_physics()

    def after_physics(self, group: list[int]) -> None:
        """Places and the explored set, contacts, explore times, the team rewards, then the rings (``TeamEnv.step``'s order)."""
        if len(group) == 1:
            super().after_physics(group)
            return
        copies = self.copies
        team, ks = self._rows(group)
        span = [copies[k] for k in group]
        first = span[0]
        c = first.config
        states = self._robot_states_of(group)
        points = states[..., :2]
        team.update_places(ks, points, first._bounds_array, first._discs_array, first.goal)
        for env in span:
            env._count_contacts()
        if type(first)._apply_events is not TeamEnv._apply_events:
            for env in span:
                env._apply_events()
        team.check_goals(ks, np.array([env.cycles for env in span]), c.dt)
        for env, reward in zip(span, team.team_rewards(ks, c.explore_reward, c.time_penalty).tolist()):
            env._reward_total += reward
            env._contact_penalties(env._reward_total)
        self._sense(team, ks, span, states.reshape(-1, states.shape[-1]))

    @staticmethod
    def _sense(team: ExplorationArrays, ks: slice | np.ndarray, span: list[Exploration], poses: np.ndarray) -> None:
        """Every copy's proximity rings: the rays of all robots of the group at once (``ProximityRing.read_many``),
        then each copy's noise from its own stream (the draws ``read_rows`` makes for it)."""
        ring, n = span[0].ring, span[0].config.n_robots
        spaces = [env.world.space for env in span for _ in range(n)]
        robots = [robot for env in span for robot in env.robot_list]
        block = np.empty((len(span) * n, ring.width), dtype=team.proximity.dtype)
        ring.read_many(spaces, robots, poses, block)
        size = ring.noise_size
        if size or not ring.noiseless:
            for j, env in enumerate(span):
                rows = block[j * n : (j + 1) * n]
                ring.apply_noise(env.np_random.standard_normal((n, size)) if size else None, rows, env.robot_list)
        team.proximity[ks] = block.reshape(len(span), n, ring.width)

    def _team_ended(self, group: list[int]) -> np.ndarray:
        """Every goal sector explored, per copy (``Exploration._terminations``)."""
        team, ks = self._rows(group)
        return team.explored_all[ks]

    def observe(self, group: list[int], out: np.ndarray) -> None:
        """Every robot row of the copies ``group`` in one pass (``Exploration._observe``'s fields); rows not live are zeroed."""
        if len(group) == 1:  # one copy: its own rows (the lone env's path) cost less than the pass
            super().observe(group, out)
            return
        copies = self.copies
        team, ks = self._rows(group)
        span = [copies[k] for k in group]
        first = span[0]
        g, n = len(span), first.config.n_robots
        s, v = first.n_sectors, first.n_sectors + first.n_doors
        slices = first.layout.slices
        block = np.zeros((g, n, out.shape[-1]), dtype=out.dtype)
        flat = block.reshape(g * n, -1)
        states = self._robot_states_of(group).reshape(g * n, -1)
        heading = states[:, 2]
        pose, velocity = slices["pose"].start, slices["velocity"].start
        flat[:, pose : pose + 2] = states[:, :2]
        flat[:, pose + 2] = remainder_tau(heading)
        flat[:, velocity] = states[:, 3] * libm(math.cos, heading) + states[:, 4] * libm(math.sin, heading)
        flat[:, velocity + 1] = states[:, 5]
        every = np.arange(g * n)
        sector, place = team.sector[ks], team.place[ks]
        flat[every, slices["sector"].start + sector.ravel()] = 1.0
        flat[every, slices["place"].start + place.ravel()] = 1.0
        block[..., slices["proximity"]] = team.proximity[ks]
        if n > 1:
            others = first._others
            steps = np.arange(n - 1)
            mates = (slices["mates_sector"].start + steps * s + sector[:, others]).reshape(g * n, -1)
            flat[every[:, None], mates] = 1.0
            mates = (slices["mates_place"].start + steps * v + place[:, others]).reshape(g * n, -1)
            flat[every[:, None], mates] = 1.0
        block[..., slices["visited"]] = team.visited[ks][:, None, :]
        block[..., slices["goal"]] = first.goal
        block[..., slices["door_belief"]] = team.door_belief[ks][:, None, :]
        block[..., slices["clutter"]] = team.clutter[ks][:, None, :]
        status_at, task_at = slices["task_status"].start, slices["task"].start
        if first._operators is None:
            block[..., status_at + int(WatcherState.WAITING)] = 1.0
            block[..., task_at] = -1.0
        else:
            for j, env in enumerate(span):
                status, tasks = env._operators.task_rows()
                block[j, np.arange(n), status_at + np.array(status)] = 1.0
                block[j, :, task_at] = tasks
        self._write_rows(group, block, out)
