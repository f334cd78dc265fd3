"""``TeamVecEnv``: a teamgym ``ParallelEnv`` as a Stable-Baselines3 ``VecEnv`` for parameter sharing.

Every ``(env copy, agent slot)`` pair is one SB3 sub-environment, so a single SB3 policy
acts for every robot (parameter sharing) and SB3 sees ``n_envs × len(possible_agents)``
independent-looking environments. Sub-environment ``k`` is agent
``possible_agents[k % A]`` of env copy ``k // A`` (``A`` agents per copy).

Padding scheme for agents that finish before their team mates
----------------------------------------------------------------

A teamgym episode lasts until every agent has terminated or been truncated; agents
drop out of ``env.agents`` one by one. For each slot:

1. While its agent is live, the slot reports the agent's own observation, reward and
   ``done=False``.
2. On the step its agent terminates or is truncated, the slot reports its reward and
   ``done=True`` once, with ``info["terminal_observation"]`` (the agent's last
   observation), ``info["TimeLimit.truncated"]`` (truncated and not terminated, so SB3
   bootstraps the value), ``info["episode"] = {"r", "l", "t"}`` (for SB3's
   ``ep_rew_mean`` logging, like ``Monitor``). The returned observation is all zeros.
3. Until the whole env copy's episode ends, the slot is *padding*: zero observation,
   zero reward, ``done=False``, ``info["padding"] = True``; its actions are ignored.
4. On the step the env copy's episode ends (the last live agents finish) the copy is
   reset automatically. Padding slots then report ``done=True`` with a zero
   ``terminal_observation`` and ``TimeLimit.truncated=False``, so the padding steps form
   their own zero-reward pseudo-episode that never bootstraps into the next real
   episode (the value of the all-zero observation is simply learned to be 0). Every slot
   of the copy returns the first observation of its agent's new episode.

Success: success is the team's (the episode contract, ``infos[agent]["success"]``), known
only when the team's episode ends. On that step every slot of the copy reports
``info["is_success"]``, the ``success`` of that step's infos, with its ``done=True``: the
``done`` of an agent that finishes then, the padding ``done`` of step 4 for one that
finished earlier. So each slot reports success exactly once per team episode and SB3's
``rollout/success_rate`` is the team's success rate. Envs whose infos hold no
``success`` get no ``is_success``.

Consequences: ``done`` counts are not episode counts (padding pseudo-episodes also end
with ``done``); do not wrap this VecEnv in ``VecMonitor`` — episode statistics come from
``info["episode"]`` as with ``Monitor``.

Box actions are clipped to the action space before they reach the env (SB3's on-policy
algorithms already clip; the env rejects out-of-bounds actions). Seeds set with
:meth:`seed` (e.g. by ``PPO(..., seed=S)``) apply to the next :meth:`reset`: env copy
``e`` is reset with the seed of its first slot, ``S + e·A``; automatic resets continue
each copy's own random stream.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from baselines.episode import success_of
from teamgym.envs.base import TeamEnv

__all__ = ["TeamVecEnv"]


class TeamVecEnv(VecEnv):
    """``n_envs`` copies of a teamgym env, one SB3 sub-environment per (copy, agent slot).

    ``env_fn()`` must return a new :class:`~teamgym.envs.base.TeamEnv` (or any PettingZoo
    ``ParallelEnv`` whose agents share one observation and one action space). See the
    module docstring for how agents that finish early are padded.
    """

    def __init__(self, env_fn: Callable[[], TeamEnv], n_envs: int = 1) -> None:
        if n_envs < 1:
            raise ValueError(f"n_envs must be >= 1, got {n_envs}")
        self.envs: list[TeamEnv] = [env_fn() for _ in range(n_envs)]
        first = self.envs[0]
        self.agent_names: list[str] = list(first.possible_agents)
        if not self.agent_names:
            raise ValueError("the env has no agents")
        self.agents_per_env = len(self.agent_names)
        observation_space = first.observation_space(self.agent_names[0])
        action_space = first.action_space(self.agent_names[0])
        for env in self.envs:
            if list(env.possible_agents) != self.agent_names:
                raise ValueError("every env copy must have the same possible_agents")
            for agent in env.possible_agents:
                if env.observation_space(agent) != observation_space or env.action_space(agent) != action_space:
                    raise ValueError(
                        f"agent {agent!r} has a different observation or action space than {self.agent_names[0]!r}; "
                        "parameter sharing needs identical spaces"
                    )
        self._slot = {agent: j for j, agent in enumerate(self.agent_names)}
        super().__init__(n_envs * self.agents_per_env, observation_space, action_space)
        self._obs = np.zeros((self.num_envs, *observation_space.shape), dtype=observation_space.dtype)
        self._live = np.zeros(self.num_envs, dtype=bool)
        self._returns = np.zeros(self.num_envs, dtype=np.float64)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._started = np.zeros(len(self.envs), dtype=np.float64)
        self._actions: np.ndarray | None = None

    # -- helpers ---------------------------------------------------------------------
    def _reset_copy(self, e: int, seed: int | None, options: dict | None) -> None:
        """Reset env copy ``e`` and refill its slots."""
        env = self.envs[e]
        observations, infos = env.reset(seed=seed, options=options or None)
        base = e * self.agents_per_env
        for j, agent in enumerate(self.agent_names):
            k = base + j
            live = agent in env.agents
            self._live[k] = live
            self._obs[k] = observations[agent] if live else 0
            self._returns[k] = 0.0
            self._lengths[k] = 0
            self.reset_infos[k] = dict(infos.get(agent, {}))
        self._started[e] = time.time()

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
        """Reset every env copy (using seeds/options set by :meth:`seed` / ``set_options``)."""
        for e in range(len(self.envs)):
            k = e * self.agents_per_env
            self._reset_copy(e, self._seeds[k], self._options[k])
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() called without step_async()")
        actions, self._actions = self._actions, None
        if len(actions) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions (one per env copy and agent), got {len(actions)}")
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        A = self.agents_per_env
        for e, env in enumerate(self.envs):
            base = e * A
            live = list(env.agents)
            step_actions = {agent: self._convert(actions[base + self._slot[agent]]) for agent in live}
            observations, step_rewards, terminations, truncations, step_infos = env.step(step_actions)
            still_live = set(env.agents)
            outcome = self._team_outcome(env, step_infos)
            for agent in live:
                k = base + self._slot[agent]
                reward = float(step_rewards.get(agent, 0.0))
                rewards[k] = reward
                self._returns[k] += reward
                self._lengths[k] += 1
                info = dict(step_infos.get(agent, {}))
                terminated = bool(terminations.get(agent, False))
                truncated = bool(truncations.get(agent, False))
                if terminated or truncated or agent not in still_live:
                    dones[k] = True
                    final = observations.get(agent)
                    info["terminal_observation"] = (
                        np.array(final, dtype=self._obs.dtype) if final is not None else np.zeros_like(self._obs[k])
                    )
                    info["TimeLimit.truncated"] = truncated and not terminated
                    info["episode"] = {
                        "r": float(self._returns[k]),
                        "l": int(self._lengths[k]),
                        "t": round(time.time() - self._started[e], 6),
                    }
                    if outcome is not None:
                        info["is_success"] = outcome
                    self._live[k] = False
                    self._obs[k] = 0
                else:
                    self._obs[k] = observations[agent]
                infos[k] = info
            for j in range(A):
                k = base + j
                if not self._live[k] and not dones[k]:
                    infos[k] = {"padding": True}
            if not env.agents:
                for j in range(A):
                    k = base + j
                    if not dones[k]:  # padding slot: close its zero pseudo-episode
                        dones[k] = True
                        infos[k] = {
                            "padding": True,
                            "terminal_observation": np.zeros_like(self._obs[k]),
                            "TimeLimit.truncated": False,
                        }
                        if outcome is not None:
                            infos[k]["is_success"] = outcome
                self._reset_copy(e, None, None)
        return self._obs.copy(), rewards, dones, infos

    def close(self) -> None:
        for env in self.envs:
            env.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Attribute of the env copy behind each sub-environment (slots of one copy share it)."""
        return [getattr(self.envs[k // self.agents_per_env], attr_name) for k in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute on the env copies behind ``indices`` (once per copy)."""
        for e in sorted({k // self.agents_per_env for k in self._indices(indices)}):
            setattr(self.envs[e], attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any) -> list[Any]:
        """Call a method once per env copy behind ``indices``; the result is repeated for each slot of a copy."""
        results: dict[int, Any] = {}
        out = []
        for k in self._indices(indices):
            e = k // self.agents_per_env
            if e not in results:
                results[e] = getattr(self.envs[e], method_name)(*method_args, **method_kwargs)
            out.append(results[e])
        return out

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """teamgym envs are never gymnasium-wrapped."""
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One frame per sub-environment (the frame of its env copy) when ``render_mode="rgb_array"``."""
        if self.render_mode != "rgb_array":
            return [None for _ in range(self.num_envs)]
        frames = [env.render() for env in self.envs]
        return [frames[k // self.agents_per_env] for k in range(self.num_envs)]
