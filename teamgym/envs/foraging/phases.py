"""Foraging's control-step phases over copies whose episode state shares one :class:`ForagingArrays`.

A lone :class:`~teamgym.envs.foraging.env.Foraging` env runs them over its own row; a
:class:`~teamgym.envs.batch.TeamBatch` of Foraging copies binds every copy to one row of a
shared ``ForagingArrays`` (:meth:`ForagingPhases.regroup`), so the batch's episode state is
one set of arrays over copies (a copy's state is a row: pickles and copies take it as a whole).

A lone env (a group of one) runs each copy's own hooks: with two or three robots its per-robot
work is a few scalar operations, cheaper than numpy passes. A group of copies whose robots are
all in their episodes runs the go-to controller, the state, goals and rewards phases and the
sensing phase as numpy passes over every robot of every copy (:mod:`teamgym.envs.foraging.group`,
the same operations and random draws), and only the radio and the rare events (a target
finished) copy by copy.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.envs.foraging.actions import GoToCellAction
from teamgym.envs.foraging.group import advance_odometry, goto_copies, perceive_copies, presence, view_geometry, wrap_angle
from teamgym.envs.foraging.sensing import Sightings
from teamgym.envs.foraging.state import ForagingArrays
from teamgym.envs.step_loop import ActionRows, CopyPhases
from teamgym.sim.robot import set_commands

if TYPE_CHECKING:
    from teamgym.envs.foraging.env import Foraging

__all__ = ["ForagingPhases"]


class ForagingPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for Foraging copies, bound to one ``ForagingArrays``."""

    copies: list[Foraging]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start

    def __init__(self, copies: list[Foraging]) -> None:
        super().__init__(copies)
        self._shared: ForagingArrays | None = None  # a batch's (made by regroup)

    def regroup(self) -> None:
        """Bind copy ``k`` to row ``k`` of one shared ``ForagingArrays`` (its row so far is copied in).

        Growing or shrinking the shared arrays replaces them, so every copy's row views are bound again.
        """
        copies = self.copies
        if self._shared is None:
            own = copies[0]._arrays
            self._shared = ForagingArrays(own.n_robots, own.n_targets, own.n_slots, n_copies=0)
        self._bind_to_shared_rows(self._shared)
        for k, env in enumerate(copies):
            env._use_rows(self._shared, k)

    # -- which path ------------------------------------------------------------------------
    #: Copies from which a group runs as numpy passes: below it, each copy's scalar hooks cost less than the
    #: passes' fixed cost (measured 2026-12-07, ``bench_batch_every_env.py``, see docs/simulator.md).
    min_group = 6

    def _together(self, group: list[int]) -> bool:
        """Whether the group runs as numpy passes: ``min_group`` copies sharing one ``ForagingArrays``, every robot live."""
        if len(group) < self.min_group:
            return False
        copies, shared = self.copies, self._shared
        for k in group:
            env = copies[k]
            if env._arrays is not shared:
                return False
            env._live_mask()
            if not env._everyone:
                return False
        return True

    # -- phases ----------------------------------------------------------------------------
    def control(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        """Commands: the go-to controller of every copy in one pass (a group), else each robot's action type."""
        first = self.copies[group[0]]
        if type(first.action_type) is GoToCellAction and self._together(group):
            self._goto(group, actions, rows)
        elif not self._act_rows(rows):
            self._act(group, actions)
        for k in group:
            self.copies[k]._before_physics()

    def _goto(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        (arrays, ks), copies = self._rows(group), self.copies
        first = copies[group[0]]
        names = first.possible_agents
        if rows is not None and len(rows[2]) == len(group) * len(names):  # every robot of every copy, in order
            cells = np.asarray(rows[2], dtype=np.int64).reshape(len(group), len(names))
        else:
            cells = np.array([[int(joint[name]) for name in names] for joint in actions], dtype=np.int64)
        c = first.config
        commands = goto_copies(
            first.controller,
            cells,
            arrays.pose[ks],
            arrays.estimate[ks],
            arrays.at[ks],
            arrays.timer[ks],
            arrays.table[ks],
            arrays.any_target[ks],
            first._cell_xy,
            first._cell_centre,
            first.grid_size,
            c.consume_time - 1e-9 if first._persist and c.task == "consume" else None,
        )
        set_commands([copies[k].robots[name] for k in group for name in names], commands.reshape(-1, 2))

    def after_physics(self, group: list[int]) -> None:
        """State, goals, rewards and sensing of every copy of a group in numpy passes (a lone env: its own hooks)."""
        if not self._together(group):
            super().after_physics(group)
            return
        (arrays, ks), copies = self._rows(group), self.copies
        span = [copies[k] for k in group]
        first = span[0]
        c, n = first.config, first.config.n_robots
        # state: true poses, odometry (eq. 2), distance travelled, the cameras' view, who is at which target
        before = arrays.pose[ks]
        after = np.stack([env.world.robot_states[:, :3] for env in span])
        wrap_angle(after[..., 2])  # θ in [−π, π), as Foraging._read_pose_rows
        noise = np.stack([env.np_random.standard_normal((2, n)) for env in span])
        odometry = first.odometry
        dx, dy, estimate, certainty = advance_odometry(
            before, after, arrays.estimate[ks], arrays.certainty[ks], noise, odometry.pe, odometry.rotation_noise,
            odometry.distance_noise,
        )  # fmt: skip
        arrays.pose[ks] = after
        arrays.travelled[ks] += np.hypot(dx, dy)
        view = view_geometry(arrays.targets[ks], after, first.cameras.landmarks)
        for env in span:
            env._geometry = None  # the lone env's lists: made again from the poses if it is ever read
        at, timer, nearest_live = presence(
            view.distance[:, :, : c.n_targets], arrays.target_live[ks], arrays.at[ks], arrays.timer[ks], c.reach_radius,
            first._persist,
        )  # fmt: skip
        done = self._check_goals(span, ks, at, timer)
        arrays.nearest_live[ks] = nearest_live
        self._finish_targets(span, ks, done)
        self._accumulate_rewards(span, ks)
        # sensing: cameras, re-localisation, perception tuples; then each copy's packets
        visible = np.ones_like(arrays.target_live[ks]) if first._persist else arrays.target_live[ks]
        table = np.empty_like(arrays.table[ks])
        sensed = perceive_copies(
            view, after, visible, estimate, certainty, [env.np_random for env in span], first.vision, first.spec.radius,
            first.cameras.clear_distance, first.grid, table,
        )  # fmt: skip
        arrays.estimate[ks], arrays.certainty[ks] = sensed.estimate, sensed.certainty
        arrays.table[ks], arrays.count[ks], arrays.any_target[ks] = table, sensed.count, sensed.any_target
        seen = sensed.any_target.tolist()
        for env, any_target in zip(span, seen):
            k = env._copy
            env._sightings = Sightings(arrays.table[k], arrays.count[k], any_target)
            if any_target and not math.isfinite(env._first_seen):
                env._first_seen = env.world.time
            env._send_packets()

    def _team_ended(self, group: list[int]) -> np.ndarray:
        """Every target finished, per copy (``Foraging._terminations``)."""
        team, ks = self._rows(group)
        return team.success[ks]

    def observe(self, group: list[int], out: np.ndarray) -> None:
        """Every robot row of a group's copies in one pass (``Foraging._observe``); the received tuples copy by copy."""
        first = self.copies[group[0]]
        if first.config.keeps_world_models or not self._together(group):
            super().observe(group, out)
            return
        (arrays, ks), copies = self._rows(group), self.copies
        span = [copies[k] for k in group]
        c, plan = first.config, first._observe_plan
        n, slots, room = c.n_robots, first.n_detections, first.n_received
        block = np.zeros((len(group), n, out.shape[-1]), dtype=out.dtype)
        block[:, :, plan.table_dst] = arrays.table[ks].reshape(len(group), n, -1)[:, :, plan.table_src]
        estimate = arrays.estimate[ks]
        (low_x, low_y), (high_x, high_y) = plan.low, plan.high
        scalars = [
            np.minimum(np.maximum(estimate[..., 0], low_x), high_x)[..., None],
            np.minimum(np.maximum(estimate[..., 1], low_y), high_y)[..., None],
            estimate[..., 2:3],
            arrays.certainty[ks][..., None],
            np.arange(slots) < arrays.count[ks][..., None],
            (arrays.at[ks] >= 0)[..., None],
        ]
        if c.task == "consume":
            scalars.append(np.minimum(1.0, arrays.timer[ks] / c.consume_time)[..., None])
        senders = np.full((len(group), n, room), -1.0)
        received = np.zeros((len(group), n, room))
        scalars += [senders, received]
        for j, env in enumerate(span):
            if not env.channel.busy:
                continue
            for i, agent in enumerate(env.possible_agents):
                sent_by = env._write_received(agent, block[j, i])
                senders[j, i, : len(sent_by)] = sent_by
                received[j, i, : len(sent_by)] = 1.0
        block[:, :, plan.scalar_dst] = np.concatenate(scalars, axis=-1, dtype=float)
        if c.comm_dim:
            for j, env in enumerate(span):
                env._observe_inbox(block[j])
        first.layout.clip(block)
        out[group] = block

    def _check_goals(self, span: list[Foraging], ks: slice | np.ndarray, at: np.ndarray, timer: np.ndarray) -> np.ndarray:
        """Goals phase of ``Foraging._check_goals`` on every copy: timers, redundant operations (``at``/``timer`` are
        written to the rows); the targets finished in this step (K, T) bool."""
        arrays, c = self._shared, span[0].config
        present = at >= 0
        arrays.finished_now[ks] = 0
        if c.task == "consume":
            np.add(timer, c.dt, out=timer, where=present)
            finished = present & (timer >= c.consume_time - 1e-9)
            if span[0]._persist and finished.any():  # at a consumed target: a redundant operation
                live_at = np.take_along_axis(arrays.target_live[ks], np.maximum(at, 0), axis=1)
                arrays.redundant[ks] += finished & ~live_at & (timer < c.consume_time + 0.5 * c.dt - 1e-9)
                finished &= live_at
            done = np.zeros(arrays.target_live[ks].shape, dtype=bool)
            rows, cols = np.nonzero(finished)
            done[rows, at[rows, cols]] = True
        else:
            t = c.n_targets
            rows, cols = np.nonzero(present)
            counts = np.bincount(rows * t + at[rows, cols], minlength=len(span) * t).reshape(len(span), t)
            done = (counts >= c.robots_per_target) & arrays.target_live[ks]
        arrays.at[ks], arrays.timer[ks] = at, timer
        return done

    def _finish_targets(self, span: list[Foraging], ks: slice | np.ndarray, done: np.ndarray) -> None:
        """The targets ``done`` (K, T) leave (copy by copy: rare), then who is at which target again; success."""
        arrays = self._shared
        for j in np.flatnonzero(done.any(axis=1)).tolist():
            env = span[j]
            now = env.world.time
            for target in np.flatnonzero(done[j]).tolist():
                env._finish_target(target, now)
            env._update_presence()
        arrays.success[ks] = ~arrays.target_live[ks].any(axis=1)

    def _accumulate_rewards(self, span: list[Foraging], ks: slice | np.ndarray) -> None:
        """The team reward of ``Foraging._accumulate_rewards`` of every copy, added to each copy's totals."""
        arrays, c = self._shared, span[0].config
        before, nearest = arrays.nearest[ks].copy(), arrays.nearest_live[ks]
        arrays.nearest[ks] = nearest
        finished = arrays.finished_now[ks][:, None]
        progress = np.where(finished > 0, 0.0, before - nearest)
        gain = c.consume_reward * finished + c.progress_reward * progress - c.time_penalty
        for env, row in zip(span, gain):
            env._reward_total += row
