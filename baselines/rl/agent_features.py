"""Extra observation features for SB3 training: the robot's index (one-hot) and the team's ``state()``.

A robot's SB3 observation becomes ``[own observation (D) | one-hot of its index (A) | team state (S)]``
(each part only when switched on; ``A = len(possible_agents)``, the index is the robot's place in
``possible_agents``; ``S = env.state_space.shape[0]``). The one-hot is ``--agent-id`` (and the
routing key of ``--independent``); the state is what the centralised critic of ``--critic central``
reads (:mod:`baselines.rl.central_critic`; the actor sees only the first ``D (+ A)`` entries).

* :class:`ObservationFeatures`: which parts are on, the widened space, and how to widen one
  observation; recorded in the sidecar as ``obs_features`` (:meth:`ObservationFeatures.sidecar`).
* :class:`FeatureTeamVecEnv`: :class:`~baselines.rl.sb3_env.TeamVecEnv` whose slots report the widened
  observations (terminal observations too: the state is the copy's state on the step the robot
  finished, read before the copy can be reset for a refill); slots that wait for a robot report zeros.
* :class:`FeatureSB3Policy`: the evaluation side, an :class:`~baselines.rl.sb3_policy.SB3Policy` that
  widens each live robot's observation the same way (state from ``env.state()`` of the env it
  acts in) before the model's one batched ``predict``. ``SB3Policy.load`` builds it when the
  model's sidecar records ``obs_features``, so ``evaluate --policy sb3:PATH`` needs nothing more.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from baselines.rl.sb3_env import TeamVecEnv
from baselines.rl.sb3_policy import SB3Policy
from teamgym.envs.base import TeamEnv

__all__ = ["FeatureSB3Policy", "FeatureTeamVecEnv", "ObservationFeatures"]


@dataclass(frozen=True)
class ObservationFeatures:
    """Which extra parts a robot's observation carries: its index one-hot, the team state."""

    agent_id: bool = False
    team_state: bool = False

    @property
    def active(self) -> bool:
        """Whether any part is added (otherwise observations are the env's own)."""
        return self.agent_id or self.team_state

    def sidecar(self) -> dict[str, bool]:
        """The sidecar's ``obs_features`` object."""
        return {"agent_id": self.agent_id, "team_state": self.team_state}

    @classmethod
    def from_sidecar(cls, sidecar: Mapping[str, Any] | None) -> ObservationFeatures:
        """The features a sidecar records (``obs_features``; none when absent: a model of a plain run)."""
        record = (sidecar or {}).get("obs_features")
        if record is None:
            return cls()
        if not isinstance(record, Mapping) or not all(isinstance(record.get(k, False), bool) for k in ("agent_id", "team_state")):
            raise ValueError(f"the sidecar's obs_features must be {{'agent_id': bool, 'team_state': bool}}, got {record!r}")
        return cls(bool(record.get("agent_id", False)), bool(record.get("team_state", False)))

    @staticmethod
    def _base_space(env: TeamEnv) -> spaces.Box:
        space = env.observation_space(env.possible_agents[0])
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ValueError(
                "--agent-id, --critic central and --independent need flat Box observations, "
                f"got {type(space).__name__} observations (use obs_format='flat')"
            )
        return space

    def dims(self, env: TeamEnv) -> tuple[int, int, int]:
        """``(D, A_or_0, S_or_0)``: the widths of the own observation, the one-hot and the state parts."""
        own = int(self._base_space(env).shape[0])
        n_agents = len(env.possible_agents) if self.agent_id else 0
        state = int(np.prod(env.state_space.shape)) if self.team_state else 0
        return own, n_agents, state

    def actor_dim(self, env: TeamEnv) -> int:
        """Width of the actor's input: the own observation and the one-hot (everything but the state)."""
        own, n_agents, _ = self.dims(env)
        return own + n_agents

    def observation_space(self, env: TeamEnv) -> spaces.Box:
        """The widened Box: own bounds, then ``[0, 1]`` for the one-hot, then the state space's bounds."""
        base = self._base_space(env)
        _, n_agents, state = self.dims(env)
        lows, highs = [base.low.astype(np.float32)], [base.high.astype(np.float32)]
        if n_agents:
            lows.append(np.zeros(n_agents, np.float32))
            highs.append(np.ones(n_agents, np.float32))
        if state:
            lows.append(np.broadcast_to(env.state_space.low, env.state_space.shape).reshape(-1).astype(np.float32))
            highs.append(np.broadcast_to(env.state_space.high, env.state_space.shape).reshape(-1).astype(np.float32))
        return spaces.Box(np.concatenate(lows), np.concatenate(highs), dtype=np.float32)

    def widen(self, observation: np.ndarray, index: int, n_agents: int, state: Callable[[], np.ndarray]) -> np.ndarray:
        """``observation`` of the robot at ``index`` (of ``n_agents``) with its parts; ``state()`` gives the team state."""
        parts = [np.asarray(observation, dtype=np.float32).reshape(-1)]
        if self.agent_id:
            parts.append(np.eye(n_agents, dtype=np.float32)[index])
        if self.team_state:
            parts.append(np.asarray(state(), dtype=np.float32).reshape(-1))
        return np.concatenate(parts)


class FeatureTeamVecEnv(TeamVecEnv):
    """:class:`TeamVecEnv` whose slots carry :class:`ObservationFeatures` (see the module docstring).

    Slots, refills, seeding and batching are :class:`TeamVecEnv`'s; only the observations (and the
    ``terminal_observation`` of a finished robot) are widened. ``base_observation_space`` is the env's.
    """

    def __init__(
        self, env_fn: Callable[[], TeamEnv], n_envs: int = 1, batched: bool | None = None, *, features: ObservationFeatures
    ) -> None:
        super().__init__(env_fn, n_envs=n_envs, batched=batched)
        self.features = features
        self.base_observation_space = self.observation_space
        self.observation_space = features.observation_space(self.envs[0])
        self._width = int(self.observation_space.shape[0])

    def _check_copy(self, env: TeamEnv, observation_space: spaces.Space, action_space: spaces.Space) -> None:
        base = getattr(self, "base_observation_space", observation_space)  # new copies are compared with the env's space
        super()._check_copy(env, base, action_space)

    def _widen_slot(self, observation: np.ndarray, row: int, e: int, states: dict[int, np.ndarray]) -> np.ndarray:
        def state() -> np.ndarray:
            if e not in states:
                states[e] = np.asarray(self.envs[e].state(), dtype=np.float32)
            return states[e]

        return self.features.widen(observation, row, self.agents_per_env, state)

    def _widened(self, observations: np.ndarray) -> np.ndarray:
        """Every slot's observation widened, as :meth:`ObservationFeatures.widen` would (a waiting slot: zeros)."""
        out = np.zeros((self.num_envs, self._width), dtype=np.float32)
        live = np.flatnonzero((self._slot_row >= 0) & np.array([a is not None for a in self._agent_of]))
        if len(live) == 0:
            return out
        own = observations.shape[1]
        out[live, :own] = observations[live]
        start = own
        if self.features.agent_id:
            out[live, start + self._slot_row[live]] = 1.0
            start += self.agents_per_env
        if self.features.team_state:
            copies = self._slot_copy[live]
            states = {int(e): np.asarray(self.envs[int(e)].state(), dtype=np.float32).reshape(-1) for e in np.unique(copies)}
            out[live, start:] = np.stack([states[int(e)] for e in copies])
        return out

    def _finish_slot(
        self, k: int, e: int, final: Any, terminated: bool, truncated: bool, info: dict, outcome: bool | None, dones: np.ndarray
    ) -> bool | None:
        row = int(self._slot_row[k])
        outcome = super()._finish_slot(k, e, final, terminated, truncated, info, outcome, dones)
        if row >= 0:  # the copy's state now: this step's, before a refill can reset the copy
            info["terminal_observation"] = self._widen_slot(info["terminal_observation"], row, e, {})
        return outcome

    def reset(self) -> np.ndarray:
        return self._widened(super().reset())

    def step_wait(self) -> Any:
        observations, rewards, dones, infos = super().step_wait()
        for info in infos:
            terminal = info.get("terminal_observation")
            if terminal is not None and np.shape(terminal) != (self._width,):  # a wait that ended: zeros
                info["terminal_observation"] = np.zeros(self._width, dtype=np.float32)
        return self._widened(observations), rewards, dones, infos


class FeatureSB3Policy(SB3Policy):
    """:class:`SB3Policy` of a model trained on widened observations (:class:`ObservationFeatures`)."""

    def __init__(
        self, env: TeamEnv, model: Any, deterministic: bool = True, codec: Any = None, *, features: ObservationFeatures
    ) -> None:
        self.features = features
        super().__init__(env, model, deterministic=deterministic, codec=codec)

    def _input_space(self, agent: str) -> spaces.Space:
        return self.features.observation_space(self.env)

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        """The model's actions for the live robots, each observation widened with its index and the env's state."""
        env = self.env
        states: list[np.ndarray] = []

        def state() -> np.ndarray:  # one state() call per step, shared by the robots
            if not states:
                states.append(np.asarray(env.state(), dtype=np.float32))
            return states[0]

        index = {agent: i for i, agent in enumerate(env.possible_agents)}
        n_agents = len(env.possible_agents)
        widened = {a: self.features.widen(obs, index[a], n_agents, state) for a, obs in observations.items()}
        return super().act(widened, infos)
