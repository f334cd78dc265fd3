"""The step loop of every teamgym env, written once over a group of env copies.

:meth:`TeamEnv.step <teamgym.envs.base.TeamEnv.step>` runs it with the env alone (a group of
one), :class:`~teamgym.envs.batch.TeamBatch` with the copies that have a robot in their
episode. The phases (the module docstring of :mod:`teamgym.envs.base` names them) run over the
whole group, phase by phase:

1. **start**: each copy logs its checked joint action (for copies and pickles) and its
   action type starts the stage (``ActionType.start``);
2. then, while a copy's stage goes on (a macro action type: each copy keeps its own stage
   clock), over the copies still in their stage: **control** (commands), **physics** (the
   worlds step Δt), then **state, events, goals, rewards, sensing**;
3. **end** (the caller's, after ``step_group``): each copy delivers its messages, admits joining
   robots, decides terminations and truncations and refreshes its masks: as dicts for a lone
   env (:meth:`TeamEnv._end_step`), as arrays for a batch (:meth:`CopyPhases.end`).

The phases of a control step are the methods of a :class:`CopyPhases` object. The default
calls each copy's own hooks one copy after another; a task whose per-step state lives in
arrays over copies (``TeamEnv.phases_class``) overrides them with one pass over the group, so
a batch of copies costs one numpy pass where a loop of envs would cost K.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.sim.robot import set_commands
from teamgym.sim.world_group import GroupPlans

if TYPE_CHECKING:
    from teamgym.envs.base import TeamEnv

__all__ = ["ActionRows", "CopyPhases", "StepArrays", "StepOutcome", "step_group"]

#: One copy's outcome of a step: rewards, terminations and truncations of the agents that were live.
StepOutcome = tuple[dict[str, float], dict[str, bool], dict[str, bool]]
#: The outcome of a group's step as arrays over (copy, robot row): rewards, terminated, truncated.
StepArrays = tuple[np.ndarray, np.ndarray, np.ndarray]
#: The checked actions of a batch step as arrays: copy index, agent row and the action of each row.
ActionRows = tuple[np.ndarray, np.ndarray, np.ndarray]


class CopyPhases:
    """The control-step phases over a group of ``copies`` (indices into the list); each copy's own hooks."""

    #: Whether a world may take its last state read as the start of its next step
    #: (``World.step(reuse_states=True)``): true for a task that moves no body between steps.
    reuse_states: bool = False

    def __init__(self, copies: Sequence[TeamEnv]) -> None:
        self.copies = copies
        self._group_plans = GroupPlans()

    def regroup(self) -> None:
        """The list of copies changed (a batch added, dropped or replaced copies)."""

    def _rows(self, group: list[int]) -> tuple[Any, slice | np.ndarray]:
        """The episode arrays of the copies ``group`` (a task's shared ones) and their rows: a slice when consecutive."""
        copies = self.copies
        first, last = copies[group[0]]._copy, copies[group[-1]]._copy
        if last - first + 1 == len(group):
            return copies[group[0]]._arrays, slice(first, last + 1)
        return copies[group[0]]._arrays, np.array([copies[k]._copy for k in group])

    def _bind_to_shared_rows(self, shared: Any) -> None:
        """Bind copy ``k`` to row ``k`` of ``shared`` (a task's arrays with ``shrink``/``grow``/``row``/``set_row``),
        copying in the rows a copy held elsewhere; copies already bound there are left alone."""
        copies = self.copies
        shared.shrink(len(copies))
        shared.grow(len(copies))
        for k, env in enumerate(copies):
            if env._arrays is shared and env._copy == k:
                continue
            shared.set_row(k, env._arrays.row(env._copy))
            env._use_rows(shared, k)

    def control(self, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None) -> None:
        """Control phase: every acting robot's body command, then each copy's ``_before_physics``.

        ``rows``: the same actions as arrays when a batch has them (a task may use them instead of the dicts).
        """
        self._act(group, actions)
        for k in group:
            self.copies[k]._before_physics()

    def _act_rows(self, rows: ActionRows | None) -> bool:
        """The acting robots' body commands from the action type's vectorised ``commands`` of the batch's ``rows``.

        False (nothing set) without rows or when the action type needs its env per robot (then :meth:`_act`).
        """
        if rows is None:
            return False
        copies = self.copies
        first = copies[int(rows[0][0])] if len(rows[0]) else copies[0]
        commands = first.action_type.commands(rows[2])
        if commands is None:
            return False
        names = first.possible_agents
        set_commands([copies[k].robots[names[i]] for k, i in zip(rows[0].tolist(), rows[1].tolist())], commands)
        return True

    def _act(self, group: list[int], actions: list[dict[str, Any]]) -> None:
        """Each acting robot's body command from its action type's ``act``: set robot by robot in one copy, over
        several copies in one pass (:func:`~teamgym.sim.robot.set_commands`, the same bits)."""
        if len(group) == 1:
            env = self.copies[group[0]]
            act, robots = env.action_type.act, env.robots
            for agent, action in actions[0].items():
                robots[agent].set_command(*act(env, agent, action))
            return
        acting, commands = [], []
        for k, joint in zip(group, actions):
            env = self.copies[k]
            act, robots = env.action_type.act, env.robots
            for agent, action in joint.items():
                acting.append(robots[agent])
                commands.append(act(env, agent, action))
        set_commands(acting, np.array(commands, dtype=float).reshape(-1, 2))

    def physics(self, group: list[int]) -> None:
        """Physics phase: each copy's world steps Δt (several together: :func:`~teamgym.sim.world_group.step_worlds`); trails."""
        reuse, copies = self.reuse_states, self.copies
        if len(group) > 1:
            self._robot_states = (group, self._group_plans.step([copies[k].world for k in group], reuse))
        else:
            self._robot_states = (group, None)
            copies[group[0]].world.step(reuse_states=reuse)
        for k in group:
            env = copies[k]
            env.cycles += 1
            if env.records_trails:
                env._record_trails()

    def _robot_states_of(self, group: list[int]) -> np.ndarray:
        """``(len(group), robots, 6)``: each copy's ``world.robot_states`` after this control step's physics, from the
        group's step when it gave them as one array (no copy's robots changed since), else stacked copy by copy."""
        states = self._group_robot_states(group)
        return np.stack([self.copies[k].world.robot_states for k in group]) if states is None else states

    def _group_robot_states(self, group: list[int]) -> np.ndarray | None:
        """The ``(len(group), robots, 6)`` robot states the group's physics step gave as one array, or ``None``."""
        stepped, states = self.__dict__.get("_robot_states", (None, None))
        return states if stepped is group else None

    def after_physics(self, group: list[int]) -> None:
        """State, events, goals, rewards and sensing phases of each copy, in that order."""
        for k in group:
            env = self.copies[k]
            env._update_state()
            env._apply_events()
            env._check_goals()
            env._accumulate_rewards(env._reward_total)
            env._sense()

    def end(self, group: list[int], rewards: np.ndarray, terminated: np.ndarray, truncated: np.ndarray) -> None:
        """End phase of each copy of ``group`` (:meth:`TeamEnv._end_step`) into rows ``[k, i]`` of the arrays.

        Where the task says which copies' teams ended (:meth:`_team_ended`), no robot joins and the
        action type has no masks, as arrays over the group (:meth:`_end_together`); else copy by copy.
        """
        copies = self.copies
        ended = self._team_ended(group) if len(group) > 1 else None
        if ended is not None and not copies[group[0]].action_type.has_masks and not any(copies[k]._joining for k in group):
            self._end_together(group, ended, rewards, terminated, truncated)
            return
        for k in group:
            env = copies[k]
            rows = env._live_rows()  # before robots join (a joining robot's reward is 0)
            rewards[k, rows] = env._reward_total[rows]
            _, terminations, truncated_now = env._end_phase()
            row = env._row
            for agent, value in terminations.items():
                if value:
                    terminated[k, row[agent]] = True
                elif truncated_now:
                    truncated[k, row[agent]] = True

    def _team_ended(self, group: list[int]) -> np.ndarray | None:
        """``(len(group),)``: whether each copy's episode ended for every live robot at once (its ``_terminations``,
        which then change nothing), or ``None`` when a task's terminations must run copy by copy (the default)."""
        return None

    def _end_together(
        self, group: list[int], ended: np.ndarray, rewards: np.ndarray, terminated: np.ndarray, truncated: np.ndarray
    ) -> None:
        """:meth:`TeamEnv._end_phase` of every copy of ``group`` as arrays: messages delivered copy by copy, then the
        team's end terminates every live robot and the cycle limit truncates the others (no robot joins, no masks)."""
        copies = self.copies
        span = [copies[k] for k in group]
        for env in span:
            env._deliver_messages()
        live = self._live_mask(group)
        at = slice(group[0], group[-1] + 1) if group[-1] - group[0] + 1 == len(group) else group
        rewards[at] = np.where(live, np.stack([env._reward_total for env in span]), rewards[at])
        over = np.array([env.cycles for env in span]) >= span[0].config.cycle_limit
        terminated[at] = live & ended[:, None]
        truncated[at] = live & ~ended[:, None] & over[:, None]

    def _write_rows(self, group: list[int], block: np.ndarray, out: np.ndarray) -> None:
        """The end of a task's ``observe`` over copies: ``block`` (``(len(group), N, width)``, every robot row) gets each
        live robot's inbox of learned messages, the clip to the layout's bounds and zeros in rows not live; then
        it goes into ``out[group]``."""
        copies = self.copies
        first = copies[group[0]]
        if first.config.comm_dim:
            for j, k in enumerate(group):
                env = copies[k]
                rows = env._live_rows()
                if len(rows):
                    inbox = block[j, rows]
                    env._observe_inbox(inbox)
                    block[j, rows] = inbox
        first.layout.clip(block)
        block[~self._live_mask(group)] = 0.0
        out[group] = block

    def _live_mask(self, group: list[int]) -> np.ndarray:
        """``(len(group), N)``: the live robots of each copy of ``group`` (columns in ``possible_agents`` order)."""
        copies = self.copies
        n = len(copies[group[0]].possible_agents)
        live = np.ones((len(group), n), dtype=bool)
        for j, k in enumerate(group):
            env = copies[k]
            if len(env.live_agents) != n:
                live[j] = False
                live[j, env._live_rows()] = True
        return live

    def going_on(self, group: list[int]) -> list[int]:
        """Positions in ``group`` of the copies whose stage goes on after this control step (:meth:`TeamEnv._stage_goes_on`)."""
        copies = self.copies
        return [i for i, k in enumerate(group) if copies[k]._stage_goes_on()]

    def observe(self, group: list[int], out: np.ndarray) -> None:
        """Rows ``out[k, i]`` of each copy ``k`` of ``group``: its live agents' observations, zeros elsewhere."""
        for k in group:
            env = self.copies[k]
            block = out[k]
            block[:] = 0
            rows = env._live_rows()
            if len(rows):
                block[rows] = env._observation_rows()


def step_group(phases: CopyPhases, group: list[int], actions: list[dict[str, Any]], rows: ActionRows | None = None) -> None:
    """Start and control steps of one ``step`` of the copies ``group`` with their checked joint ``actions``.

    The caller has checked every action and that every copy has a live agent; the end phase,
    observations, infos and the agents' leaving are the caller's (a lone env's dicts, a batch's arrays).
    """
    copies = phases.copies
    for k, joint in zip(group, actions):
        env = copies[k]
        env._log.append(("step", joint))
        env._reward_total[:] = 0.0
        env.action_type.start(env, joint)
    running, running_actions, running_rows = group, actions, rows
    while running:
        phases.control(running, running_actions, running_rows)
        phases.physics(running)
        phases.after_physics(running)
        going_on = phases.going_on(running)
        if len(going_on) < len(running):
            running = [running[i] for i in going_on]
            running_actions = [running_actions[i] for i in going_on]
            running_rows = None
