"""K copies of a teamgym env stepped as one ``teamgym.make_batch`` batch inside an RLlib env runner.

RLlib's ``MultiAgentEnvRunner`` vectorises a multi-agent env only by stepping ``num_envs_per_env_runner``
separate copies in a Python loop (``SyncVectorMultiAgentEnv``). :class:`TeamVectorMultiAgentEnv` is the
same ``VectorMultiAgentEnv`` interface on one :class:`teamgym.envs.batch.TeamBatch`, so the copies go
through the env's step phases over copies (one numpy pass where the task keeps its state in arrays);
:class:`TeamBatchEnvRunner` is the env runner that builds it. :func:`baselines.rl.rllib.ppo_config`
uses both when ``envs_per_runner > 1`` (``python -m baselines.rl.rllib --envs-per-runner K``).

What RLlib sees is what ``SyncVectorMultiAgentEnv`` of :class:`baselines.rl.rllib.TeamMultiAgentEnv`
copies would give with the same seeds and actions, value for value (tests/baselines/test_rllib.py):
per copy, the agents of one step are the robots that acted plus any that joined; ``"__all__"``
follows :func:`baselines.rl.rllib.episode_flags`; a copy whose episode ended is reset on the next
``step`` (RLlib's ``"next_step"`` auto-reset: that step returns its new episode's first observations,
zero rewards and no flags) and continues its own random stream, as ``reset()`` without a seed does.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from baselines.rl.rllib import DEFAULT_ENV, TeamMultiAgentEnv, episode_flags, require_rllib, with_masks

try:  # module-level classes: Ray pickles them by reference into remote env runners
    from ray.rllib.callbacks.utils import make_callback
    from ray.rllib.env.env_context import EnvContext
    from ray.rllib.env.multi_agent_env_runner import MultiAgentEnvRunner as _EnvRunner
    from ray.rllib.env.vector.vector_multi_agent_env import VectorMultiAgentEnv as _VectorEnv
except ImportError:  # ray[rllib] missing: importing still works; using it raises (require_rllib)
    _EnvRunner = object  # type: ignore[assignment,misc]
    _VectorEnv = object  # type: ignore[assignment,misc]

__all__ = ["TeamBatchEnvRunner", "TeamVectorMultiAgentEnv"]


class TeamVectorMultiAgentEnv(_VectorEnv):
    """``num_envs`` copies of ``env_config["env_id"]`` (config ``env_config["config"]``) as one RLlib vector env.

    ``envs[k]`` is a :class:`TeamMultiAgentEnv` view of copy ``k`` (RLlib reads each sub-env's spaces
    and ``possible_agents`` from it); stepping goes through :attr:`batch` only.
    """

    def __init__(self, env_config: Mapping[str, Any] | None = None, num_envs: int = 1) -> None:
        require_rllib()
        import gymnasium as gym

        import teamgym

        super().__init__()
        env_config = dict(env_config or {})
        self.batch = teamgym.make_batch(env_config.get("env_id", DEFAULT_ENV), num_envs, **dict(env_config.get("config") or {}))
        self.envs = [TeamMultiAgentEnv(env=copy) for copy in self.batch.copies]  # spaces checked here, one-line errors
        view = self.envs[0]
        self.num_envs = num_envs
        self.possible_agents = list(view.possible_agents)
        #: Row of each agent in the batch's arrays (``possible_agents`` order).
        self.row_of = {a: i for i, a in enumerate(self.possible_agents)}
        self.masked = view.masked
        self.metadata = {"autoreset_mode": "next_step"}
        self.single_observation_spaces = dict(view.observation_spaces)
        self.single_action_spaces = dict(view.action_spaces)
        self.single_observation_space = gym.spaces.Dict(self.single_observation_spaces)
        self.single_action_space = gym.spaces.Dict(self.single_action_spaces)
        self._pending_reset = np.zeros(num_envs, dtype=bool)
        self._fill = _idle_action(self.batch.action_space)

    # -- the VectorMultiAgentEnv interface -------------------------------------------
    def reset(
        self, *, seed: int | Sequence[int | None] | None = None, options: dict | None = None
    ) -> tuple[list[dict], list[dict]]:
        """Every copy starts an episode: copy ``k`` with ``seed + k`` (or ``seed[k]``; ``None``: its own stream)."""
        seeds = _copy_seeds(seed, self.num_envs)
        observations, infos = [], []
        for k, copy_seed in enumerate(seeds):
            obs, info = self._reset_copy(k, copy_seed, options)
            observations.append(obs)
            infos.append(info)
        self._pending_reset[:] = False
        return observations, infos

    def step(self, actions: Sequence[Mapping[str, Any]]) -> tuple[list, list, list, list, list]:
        """One step of every copy (``actions[k]``: copy ``k``'s actions by agent); ended copies restart instead."""
        if len(actions) != self.num_envs:
            raise ValueError(f"{type(self).__name__}.step(): {len(actions)} action dicts for {self.num_envs} copies")
        batch = self.batch
        acting = batch.active.copy()
        restarting = self._pending_reset.copy()
        stepped = batch.step(self._action_array(actions, acting)) if acting.any() else None
        outcome = _StepOutcome(self.num_envs)
        for k in range(self.num_envs):
            if restarting[k]:
                outcome.restart(k, *self._reset_copy(k, None, None), self.possible_agents)
            elif stepped is not None and acting[k].any():
                agents = [a for i, a in enumerate(self.possible_agents) if acting[k, i] or batch.active[k, i]]
                outcome.stepped(k, self, agents, stepped)
        self._pending_reset = np.array(
            [bool(ends["__all__"] or cuts["__all__"]) for ends, cuts in zip(outcome.terminations, outcome.truncations)]
        )
        return outcome.observations, outcome.rewards, outcome.terminations, outcome.truncations, outcome.infos

    def render(self) -> tuple[Any, ...]:
        return tuple(self.batch.render(k) for k in range(self.num_envs))

    def close_extras(self, **kwargs: Any) -> None:
        self.batch.close()

    # -- helpers ---------------------------------------------------------------------
    def _reset_copy(self, k: int, seed: int | None, options: dict | None) -> tuple[dict, dict]:
        rows, infos = self.batch.reset_copy(k, seed, options)
        agents = [a for i, a in enumerate(self.possible_agents) if self.batch.active[k, i]]
        return self.observations_of(k, rows, agents), infos

    def observations_of(self, k: int, rows: np.ndarray, agents: list[str]) -> dict[str, Any]:
        """What RLlib sees of copy ``k``'s ``agents`` from its observation ``rows`` (with masks for a masked action type)."""
        row = self.row_of
        observations = {a: rows[row[a]] for a in agents}
        if not self.masked:
            return observations
        masks, live = self.batch.action_masks()[k], self.batch.active[k]
        # as the env's action_masks(): live agents only (a robot that just finished observes all ones)
        return with_masks(observations, {a: masks[row[a]] for a in agents if live[row[a]]}, masks.shape[-1])

    def _action_array(self, actions: Sequence[Mapping[str, Any]], acting: np.ndarray) -> np.ndarray:
        """``(K, N, ...)`` actions: each acting row's from ``actions``, the idle action elsewhere (the batch ignores it)."""
        space = self.batch.action_space
        array = np.empty((self.num_envs, len(self.possible_agents), *(space.shape or ())), dtype=space.dtype)
        array[...] = self._fill
        for k, i in zip(*np.nonzero(acting)):
            agent = self.possible_agents[i]
            try:
                array[k, i] = actions[k][agent]
            except KeyError:
                raise ValueError(f"{type(self).__name__}.step(): copy {k} has no action for live agent {agent!r}") from None
        return array


class _StepOutcome:
    """The five per-copy lists one vector step returns."""

    def __init__(self, n_copies: int) -> None:
        self.observations: list[dict] = [{} for _ in range(n_copies)]
        self.rewards: list[dict] = [{} for _ in range(n_copies)]
        self.terminations: list[dict] = [{} for _ in range(n_copies)]
        self.truncations: list[dict] = [{} for _ in range(n_copies)]
        self.infos: list[dict] = [{} for _ in range(n_copies)]

    def restart(self, k: int, observations: dict, infos: dict, possible_agents: list[str]) -> None:
        self.observations[k], self.infos[k] = observations, infos
        self.rewards[k] = dict.fromkeys(possible_agents, 0.0)
        self.terminations[k] = {**dict.fromkeys(possible_agents, False), "__all__": False}
        self.truncations[k] = {**dict.fromkeys(possible_agents, False), "__all__": False}

    def stepped(self, k: int, env: TeamVectorMultiAgentEnv, agents: list[str], stepped: tuple) -> None:
        observations, rewards, terminated, truncated = stepped
        rows = env.row_of
        self.observations[k] = env.observations_of(k, observations[k], agents)
        self.rewards[k] = {a: float(rewards[k, rows[a]]) for a in agents}
        over = not env.batch.active[k].any()
        self.terminations[k], self.truncations[k] = episode_flags(
            {a: bool(terminated[k, rows[a]]) for a in agents}, {a: bool(truncated[k, rows[a]]) for a in agents}, over
        )
        infos = env.batch.infos(k)
        self.infos[k] = {a: infos[a] for a in agents}


def _copy_seeds(seed: int | Sequence[int | None] | None, n: int) -> list[int | None]:
    if seed is None:
        return [None] * n
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        return [int(seed) + k for k in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"reset(seed=...): {len(seeds)} seeds for {n} copies")
    return seeds


def _idle_action(space: Any) -> Any:
    """A valid action of ``space`` for rows the batch ignores (Box: its low corner clipped to 0; Discrete: 0)."""
    if getattr(space, "shape", None):
        return np.clip(np.zeros(space.shape, dtype=space.dtype), space.low, space.high)
    return np.zeros((), dtype=space.dtype)


class TeamBatchEnvRunner(_EnvRunner):
    """RLlib's ``MultiAgentEnvRunner`` whose env is one :class:`TeamVectorMultiAgentEnv` of ``num_envs_per_env_runner`` copies."""

    def make_env(self) -> None:
        require_rllib()
        if self.env is not None:
            self.env.close()
            del self.env
        env_ctx = self.config.env_config
        if not isinstance(env_ctx, EnvContext):
            env_ctx = EnvContext(env_ctx, worker_index=self.worker_index, num_workers=self.config.num_env_runners, remote=False)
        self.env = TeamVectorMultiAgentEnv(dict(env_ctx), self.config.num_envs_per_env_runner)
        self.num_envs = self.env.num_envs
        self._needs_initial_reset = True
        make_callback(
            "on_environment_created",
            callbacks_objects=self._callbacks,
            callbacks_functions=self.config.callbacks_on_environment_created,
            kwargs=dict(env_runner=self, metrics_logger=self.metrics, env=self.env.unwrapped, env_context=env_ctx),
        )
