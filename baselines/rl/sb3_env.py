"""``TeamVecEnv``: teamgym ``ParallelEnv`` copies as one Stable-Baselines3 ``VecEnv`` for parameter sharing.

SB3 sees ``n_envs × A`` sub-environments (*slots*; ``A = len(possible_agents)``) and one
policy acts for every robot (parameter sharing). Each slot carries one robot's episode at a
time; timesteps count *agent* transitions.

Slots are refilled across env copies
------------------------------------

A teamgym episode lasts until every robot has finished; robots leave ``env.agents`` one by
one (a Navigation robot that arrives, say). An adapter that ties slot ``k`` to robot
``k % A`` of copy ``k // A`` must fill the slots of finished robots with padding until the
whole team is done: on Navigation-v0 that was about a third of every PPO batch, zero
observations that PPO trained on and counted as timesteps. Here a slot is free as soon as
its robot finishes, and free slots are *re-filled*: as soon as ``A`` slots are free, an env
copy whose episode is over (or a new copy from ``env_fn`` when none is idle) is reset and
its ``A`` robots take those slots, longest-waiting slot first. The pool of copies grows
only as far as needed (at most one copy per slot). Only a slot that waits for ``A - 1``
others to free up is padding, so the padding share falls with ``n_envs``; it is counted in
:attr:`TeamVecEnv.padding_share`. See docs/training.md for measured shares.

What a slot reports:

1. While its robot is live: the robot's observation, reward and ``done=False``.
2. On the step its robot finishes: its reward and ``done=True`` with
   ``info["terminal_observation"]``, ``info["TimeLimit.truncated"]`` (truncated and not
   terminated, so SB3 bootstraps the value) and ``info["episode"] = {"r", "l", "t"}`` (the
   robot's true return and length, as ``Monitor`` writes them). The returned observation
   is the first observation of the robot that takes the slot on this step, or zeros.
3. While it waits for a robot: zero observation and reward, ``done=False``,
   ``info["padding"] = True``; its actions are ignored. When a robot takes it, the wait
   ends with ``done=True``, a zero ``terminal_observation``, ``TimeLimit.truncated=False``
   and no ``"episode"`` (so SB3 never bootstraps a wait into a real episode, and episode
   statistics skip it).

Because slots write ``info["episode"]`` themselves, :meth:`TeamVecEnv.env_is_wrapped`
answers ``True`` for ``Monitor``: SB3's ``evaluate_policy`` and ``EvalCallback`` then count
robot episodes with their true returns and skip waits. Do not wrap this VecEnv in
``VecMonitor``.

Success is the team's (the episode contract, ``infos[agent]["success"]``), known when the
team's episode ends. On that step ``info["is_success"]`` goes with the ``done`` of *one*
robot that finishes then (the first in ``possible_agents`` order), so SB3's
``rollout/success_rate`` counts each team episode once. Envs whose infos hold no
``success`` get no ``is_success``.

Copies stepped as one batch
---------------------------

When ``env_fn()`` returns a bare :class:`~teamgym.envs.base.TeamEnv` (any id, flat
observations, no render mode, ``fixed_agents=False``), its copies are one
:class:`~teamgym.envs.batch.TeamBatch` (:meth:`~teamgym.envs.base.TeamEnv.make_batch`) and
are stepped together (``batched=None``, the default; ``True`` insists, ``False`` refuses):
one array of actions for all copies. Slots, refills, seeding and what a finishing robot's
``info`` holds are exactly the PettingZoo path's (tests/baselines/test_sb3_batched.py, on every env);
a slot whose robot goes on gets an empty ``info`` instead of the robot's per-step metrics.
Wrapped envs (and dict observations) are stepped one by one through the PettingZoo API.

Box actions are clipped to the action space before they reach the env. For ``Discrete`` and
``MultiDiscrete`` actions with masks (Exploration's operator actions),
:meth:`TeamVecEnv.action_masks` gives sb3-contrib's ``MaskablePPO`` one row per slot.
Seeds set with :meth:`seed` (e.g. by ``PPO(..., seed=S)``) apply to the next
:meth:`reset`: copy ``e`` is reset with ``S + e·A``, also copies added to the pool later
(numbered from ``n_envs`` on);
automatic resets continue each copy's own random stream, so runs are bit-identical.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from baselines.episode import success_of
from teamgym.envs.base import TeamEnv

__all__ = ["TeamVecEnv"]


class TeamVecEnv(VecEnv):
    """``n_envs × A`` SB3 sub-environments (slots) served by a pool of teamgym env copies.

    ``env_fn()`` must return a new :class:`~teamgym.envs.base.TeamEnv` (or any PettingZoo
    ``ParallelEnv`` whose agents share one observation and one action space). See the
    module docstring for how slots are refilled when robots finish early.
    """

    def __init__(self, env_fn: Callable[[], TeamEnv], n_envs: int = 1, batched: bool | None = None) -> None:
        if n_envs < 1:
            raise ValueError(f"n_envs must be >= 1, got {n_envs}")
        self._env_fn = env_fn
        first = env_fn()
        self._batch = self._make_batch(first, n_envs, batched)
        if self._batch is not None:
            first.close()
            self.envs: list[TeamEnv] = self._batch.copies  # the batch's list: copies it adds appear here
        else:
            self.envs = [first] + [env_fn() for _ in range(n_envs - 1)]
        first = self.envs[0]
        self.agent_names: list[str] = list(first.possible_agents)
        if not self.agent_names:
            raise ValueError("the env has no agents")
        self.agents_per_env = len(self.agent_names)
        observation_space = first.observation_space(self.agent_names[0])
        action_space = first.action_space(self.agent_names[0])
        for env in self.envs:
            self._check_copy(env, observation_space, action_space)
        A = self.agents_per_env
        self._copy_of = [k // A for k in range(n_envs * A)]  # the copy each slot serves (or served last)
        super().__init__(n_envs * A, observation_space, action_space)  # reads render_mode through get_attr
        self._obs = np.zeros((self.num_envs, *observation_space.shape), dtype=observation_space.dtype)
        self._returns = np.zeros(self.num_envs, dtype=np.float64)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._actions: np.ndarray | None = None
        self._slot_copy = np.array(self._copy_of, dtype=np.int64)  # the same, as an array (batched stepping)
        self._slot_row = np.full(self.num_envs, -1, dtype=np.int64)  # row of the slot's robot in its copy; -1 while waiting
        self._row_of = {agent: i for i, agent in enumerate(self.agent_names)}
        self._agent_of: list[str | None] = [None] * self.num_envs  # the robot in each slot; None while waiting
        self._slots: list[dict[str, int]] = [{} for _ in self.envs]  # per copy: live robot -> slot
        self._started = [0.0 for _ in self.envs]
        self._idle: deque[int] = deque()  # copies whose episode is over
        self._waiting: deque[int] = deque()  # free slots, longest waiting first
        self._base_seed: int | None = None
        #: Copies added to the pool are numbered ``start + j·stride`` (``j`` = 0, 1, …) for
        #: seeding, after the ``n_envs`` first ones; :class:`~baselines.rl.subproc.SubprocTeamVecEnv`
        #: interleaves its workers' numbers so no two copies share a seed.
        self.extra_copy_numbers = (n_envs, 1)
        #: Global index of this VecEnv's first slot when it serves part of a larger one (workers).
        self.slot_offset = 0
        self.slot_steps = 0
        self.padding_steps = 0

    @staticmethod
    def _make_batch(first: TeamEnv, n_envs: int, batched: bool | None) -> Any | None:
        """The env's batch (``make_batch``) for ``batched`` = True or None (when the copies can be one); None for False.

        A batch takes a bare TeamEnv (a wrapper, say one that labels expert actions, must see every
        step) with flat observations, no render mode and ``fixed_agents=False`` (the batch has fixed rows).
        """
        if batched is False:
            return None
        plain = isinstance(first, TeamEnv) and first.render_mode is None
        why = None
        if not plain:
            why = f"{type(first).__name__} is not a bare teamgym env without a render mode"
        elif first.config.fixed_agents:
            why = "fixed_agents=True (a batch has fixed rows of its own)"
        elif not isinstance(first.observation_space(first.possible_agents[0]), spaces.Box):
            why = f"obs_format={first.config.obs_format!r} (the adapter stacks flat observations)"
        if why is None:
            return first.make_batch(n_envs)
        if batched:
            raise ValueError(f"these copies cannot be stepped as one batch: {why}; use batched=False or None")
        return None

    @property
    def batched(self) -> bool:
        """Whether the copies are stepped together by the env's batch form (one numpy pass) rather than one by one."""
        return self._batch is not None

    def _check_copy(self, env: TeamEnv, observation_space: spaces.Space, action_space: spaces.Space) -> None:
        if list(env.possible_agents) != self.agent_names:
            raise ValueError("every env copy must have the same possible_agents")
        for agent in env.possible_agents:
            if env.observation_space(agent) != observation_space or env.action_space(agent) != action_space:
                raise ValueError(
                    f"agent {agent!r} has a different observation or action space than {self.agent_names[0]!r}; "
                    "parameter sharing needs identical spaces"
                )

    @property
    def padding_share(self) -> float:
        """Share of slot-steps since construction that were padding (a slot waiting for a robot)."""
        return self.padding_steps / self.slot_steps if self.slot_steps else 0.0

    # -- slots and copies ------------------------------------------------------------
    def _start_copy(self, e: int, slots: Sequence[int], seed: int | None, options: dict | None) -> list[int]:
        """Reset copy ``e`` and put its robots in ``slots`` (in ``possible_agents`` order); returns unused slots."""
        env = self.envs[e]
        if self._batch is not None:
            rows, infos = self._batch.reset_copy(e, seed=seed, options=options or None)
            observations = {agent: rows[self._row_of[agent]] for agent in env.agents}
        else:
            observations, infos = env.reset(seed=seed, options=options or None)
        binding: dict[str, int] = {}
        free = list(slots)
        for agent in self.agent_names:
            if agent not in env.agents or not free:
                continue
            k = free.pop(0)
            binding[agent] = k
            self._agent_of[k] = agent
            self._copy_of[k] = e
            self._slot_copy[k] = e
            self._slot_row[k] = self._row_of[agent]
            self._obs[k] = observations[agent]
            self._returns[k] = 0.0
            self._lengths[k] = 0
            self.reset_infos[k] = dict(infos.get(agent, {}))
        self._slots[e] = binding
        self._started[e] = time.time()
        return free

    def _copy_for_refill(self) -> tuple[int, int | None]:
        """An idle copy (continuing its random stream), or a new one seeded after the others."""
        if self._idle:
            return self._idle.popleft(), None
        if self._batch is not None:
            self._batch.add_copy()  # appears in self.envs, the batch's list
        else:
            env = self._env_fn()
            self._check_copy(env, self.observation_space, self.action_space)
            self.envs.append(env)
        self._slots.append({})
        self._started.append(0.0)
        e = len(self.envs) - 1
        start, stride = self.extra_copy_numbers
        number = start + (e - self.num_envs // self.agents_per_env) * stride
        seed = None if self._base_seed is None else self._base_seed + number * self.agents_per_env
        return e, seed

    def _refill(self, dones: np.ndarray, infos: list[dict[str, Any]]) -> None:
        """Start copies for free slots, ``A`` at a time; a slot that waited closes its wait with ``done``."""
        A = self.agents_per_env
        while len(self._waiting) >= A:
            slots = [self._waiting.popleft() for _ in range(A)]
            for k in slots:
                if not dones[k]:  # it waited: end the padding pseudo-episode
                    dones[k] = True
                    infos[k] = {
                        "padding": True,
                        "terminal_observation": np.zeros_like(self._obs[k]),
                        "TimeLimit.truncated": False,
                    }
            e, seed = self._copy_for_refill()
            unused = self._start_copy(e, slots, seed, None)
            if len(unused) == A:  # the copy started with no live robot: nothing can take the slots
                raise RuntimeError("an env copy started with no live agents")
            self._waiting.extendleft(reversed(unused))

    @staticmethod
    def _team_outcome(env: TeamEnv, infos: dict[str, dict[str, Any]]) -> bool | None:
        """The team's success if this step ended the copy's episode and the env reports success, else ``None``."""
        if env.agents or not any("success" in info for info in infos.values()):
            return None
        return success_of(infos)

    def _convert(self, action: Any) -> Any:
        space = self.action_space
        if isinstance(space, spaces.Discrete):
            return int(np.asarray(action).reshape(()))
        if isinstance(space, spaces.Box):
            return np.clip(np.asarray(action, dtype=space.dtype).reshape(space.shape), space.low, space.high)
        return action

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        return list(self._get_indices(indices))

    # -- VecEnv API ------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        """Reset the first ``n_envs`` copies into slots ``e·A … e·A + A - 1`` (seeds/options from :meth:`seed`)."""
        A = self.agents_per_env
        first = self._seeds[0] if self._seeds else None
        self._base_seed = None if first is None else first - self.slot_offset
        for env in self.envs[self.num_envs // A :]:  # copies added by refills: a reset starts afresh
            env.close()
        if self._batch is not None:
            self._batch.truncate(self.num_envs // A)
        else:
            del self.envs[self.num_envs // A :]
        self._agent_of = [None] * self.num_envs
        self._slot_row[:] = -1
        self._slots = [{} for _ in self.envs]
        self._started = [0.0 for _ in self.envs]
        self._waiting.clear()
        self._idle.clear()
        for e in range(self.num_envs // A):
            k = e * A
            unused = self._start_copy(e, range(k, k + A), self._seeds[k], self._options[k])
            self._waiting.extend(unused)
        for k in self._waiting:
            self._obs[k] = 0
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seeds for the next :meth:`reset`: slot ``k`` gets ``seed + k``; copy ``e`` is reset with ``seed + e·A``."""
        return super().seed(seed)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() called without step_async()")
        actions, self._actions = self._actions, None
        if len(actions) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions (one per slot), got {len(actions)}")
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        self.slot_steps += self.num_envs
        self.padding_steps += len(self._waiting)
        for k in self._waiting:
            infos[k] = {"padding": True}
        if self._batch is not None:
            self._step_batch(actions, rewards, dones, infos)
        else:
            self._step_copies(actions, rewards, dones, infos)
        self._refill(dones, infos)
        return self._obs.copy(), rewards, dones, infos

    def _step_copies(self, actions: np.ndarray, rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]]) -> None:
        """Step the copies one after another through the PettingZoo API."""
        for e, env in enumerate(self.envs):
            binding = self._slots[e]
            if not binding:
                continue
            live = [agent for agent in self.agent_names if agent in binding]
            observations, step_rewards, terminations, truncations, step_infos = env.step(
                {agent: self._convert(actions[binding[agent]]) for agent in live}
            )
            still_live = set(env.agents)
            outcome = self._team_outcome(env, step_infos)
            for agent in live:
                k = binding[agent]
                reward = float(step_rewards.get(agent, 0.0))
                rewards[k] = reward
                self._returns[k] += reward
                self._lengths[k] += 1
                info = dict(step_infos.get(agent, {}))
                terminated = bool(terminations.get(agent, False))
                truncated = bool(truncations.get(agent, False))
                if terminated or truncated or agent not in still_live:
                    final = observations.get(agent)
                    outcome = self._finish_slot(k, e, final, terminated, truncated, info, outcome, dones)
                else:
                    self._obs[k] = observations[agent]
                infos[k] = info
            if not env.agents:
                for agent in list(binding):  # robots the env dropped without a done flag
                    self._waiting.append(binding.pop(agent))
                self._idle.append(e)

    def _step_batch(self, actions: np.ndarray, rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]]) -> None:
        """Step every copy at once through the env's batch form; slots read their rows of its arrays.

        Slots whose robot goes on get an empty ``info``; a robot that finishes gets its metrics
        (``batch.infos``) as the PettingZoo path gives them on that step.
        """
        batch = self._batch
        bound = np.flatnonzero(self._slot_row >= 0)
        ks, rows = self._slot_copy[bound], self._slot_row[bound]
        space = self.action_space
        moves = np.zeros((batch.n_copies, batch.n_robots, *space.shape), dtype=space.dtype)
        chosen = np.asarray(actions)[bound]
        moves[ks, rows] = np.clip(chosen, space.low, space.high) if isinstance(space, spaces.Box) else chosen
        observations, step_rewards, terminated, truncated = batch.step(moves)
        reward = step_rewards[ks, rows]
        rewards[bound] = reward
        self._returns[bound] += reward
        self._lengths[bound] += 1
        self._obs[bound] = observations[ks, rows]
        finished = np.flatnonzero(terminated[ks, rows] | truncated[ks, rows])
        if len(finished) == 0:
            return
        order = sorted(finished.tolist(), key=lambda j: (ks[j], rows[j]))  # copy, then agent order: as _step_copies
        over = batch.episode_over()
        for e in sorted({int(ks[j]) for j in order}):
            copy_infos = batch.infos(e)
            outcome = bool(batch.copies[e].episode_success()) if over[e] else None
            for j in (j for j in order if ks[j] == e):
                k, i = int(bound[j]), int(rows[j])
                info = copy_infos[self.agent_names[i]]
                term, trunc = bool(terminated[e, i]), bool(truncated[e, i])
                outcome = self._finish_slot(k, e, observations[e, i], term, trunc, info, outcome, dones)
                infos[k] = info
            if over[e]:
                self._idle.append(e)

    def _finish_slot(
        self, k: int, e: int, final: Any, terminated: bool, truncated: bool, info: dict, outcome: bool | None, dones: np.ndarray
    ) -> bool | None:
        """Slot ``k``'s robot finished: ``done``, its terminal observation and episode in ``info``; the slot waits.

        ``outcome`` (the team's success, once the copy's episode is over) goes to the first robot
        that finishes then; returns what is left of it for the others.
        """
        dones[k] = True
        zeros = np.zeros_like(self._obs[k])
        info["terminal_observation"] = np.array(final, dtype=self._obs.dtype) if final is not None else zeros
        info["TimeLimit.truncated"] = truncated and not terminated
        elapsed = round(time.time() - self._started[e], 6)
        info["episode"] = {"r": float(self._returns[k]), "l": int(self._lengths[k]), "t": elapsed}
        if outcome is not None:
            info["is_success"] = outcome
            outcome = None  # once per team episode
        agent = self._agent_of[k]
        if agent is not None:
            self._slots[e].pop(agent, None)
        self._agent_of[k] = None
        self._slot_row[k] = -1
        self._obs[k] = 0
        self._waiting.append(k)
        return outcome

    def action_masks(self) -> np.ndarray:
        """One mask row per slot for sb3-contrib's ``MaskablePPO`` (waiting slots: every action allowed)."""
        space = self.action_space
        if isinstance(space, spaces.Discrete):
            width = int(space.n)
        elif isinstance(space, spaces.MultiDiscrete):
            width = int(np.sum(space.nvec))
        else:
            raise TypeError(f"action masks need Discrete or MultiDiscrete actions, not {type(space).__name__}")
        masks = np.ones((self.num_envs, width), dtype=bool)
        for k, agent in enumerate(self._agent_of):
            if agent is None:
                continue
            env = self.envs[self._copy_of[k]]
            mask = env.action_masks().get(agent) if hasattr(env, "action_masks") else None
            if mask is not None:
                masks[k] = np.asarray(mask, dtype=bool).reshape(width)
        return masks

    def close(self) -> None:
        for env in self.envs:
            env.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Attribute of the env copy each slot serves (or served last, while it waits)."""
        return [getattr(self.envs[self._copy_of[k]], attr_name) for k in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute once per copy behind ``indices`` (``None``: every copy in the pool)."""
        copies = range(len(self.envs)) if indices is None else sorted({self._copy_of[k] for k in self._indices(indices)})
        for e in copies:
            setattr(self.envs[e], attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any) -> list[Any]:
        """Call a method once per env copy behind ``indices``; the result is repeated for each slot it serves.

        ``"action_masks"`` is answered per slot by :meth:`action_masks` (sb3-contrib's
        ``get_action_masks`` asks every sub-environment through ``env_method``).
        """
        if method_name == "action_masks":
            masks = self.action_masks()
            return [masks[k] for k in self._indices(indices)]
        results: dict[int, Any] = {}
        out = []
        for k in self._indices(indices):
            e = self._copy_of[k]
            if e not in results:
                results[e] = getattr(self.envs[e], method_name)(*method_args, **method_kwargs)
            out.append(results[e])
        return out

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """``True`` for ``Monitor`` only: slots write Monitor's ``info["episode"]`` themselves."""
        wrapped = wrapper_class is Monitor
        return [wrapped for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One frame per slot (the frame of the copy it serves) when ``render_mode="rgb_array"``."""
        if self.render_mode != "rgb_array":
            return [None for _ in range(self.num_envs)]
        frames = {e: self.envs[e].render() for e in sorted(set(self._copy_of))}
        return [frames[self._copy_of[k]] for k in range(self.num_envs)]
