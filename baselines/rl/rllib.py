"""Train one parameter-shared policy on a teamgym env with Ray RLlib (new API stack, PPO).

Command line::

    python -m baselines.rl.rllib [--env Navigation-v0] [--iterations 10] [--set key=value ...]
        [--hp key=value ...] [--defaults] [--seed 0] [--out DIR] [--env-runners 0] [--envs-per-runner 1]
        [--num-cpus N | --ray-address HOST:PORT] [--threads 1] [--eval-episodes K] [--eval-seed 10000]
        [--evaluate CHECKPOINT]

Trains PPO with one RLModule (``"shared"``) that every robot maps to, saves an RLlib
checkpoint to ``--out`` (default ``results/rllib/<env>_ppo``) with its sidecar ``teamgym.json`` in it
(the one sidecar format of :mod:`baselines.learned`: env id, config overrides, resolved config, PPO
settings, per-iteration results) and, with ``--eval-episodes``,
evaluates the trained module greedily on held-out seeds through :func:`baselines.episode.run_episode`
(the loop of ``baselines.evaluate``). ``--hp`` sets :meth:`PPOConfig.training` keywords (e.g.
``lr=1e-4``); ``--defaults`` starts from RLlib's own PPO defaults instead of :data:`TESTED_SETTINGS`.
``--evaluate CHECKPOINT`` only evaluates a saved checkpoint (env and config from its ``teamgym.json``);
``python -m baselines.evaluate --policy rllib:CHECKPOINT`` evaluates one with the evaluation CLI's
options and outputs.
``--ray-address`` trains on an existing Ray cluster (the env runners anywhere on it, the learner here).

Pieces, for use from Python (see docs/scale_out.md):

* :class:`TeamMultiAgentEnv`: any teamgym env as an RLlib ``MultiAgentEnv``. Agents that finish
  early drop out (RLlib's new API stack handles that natively), the episode's end and time
  limits are reported so that RLlib bootstraps truncated robots, and Discrete action masks
  become a ``Dict(observations=..., action_mask=...)`` observation (:class:`MaskedPPOTorchRLModule`).
* :func:`ppo_config`: a ``PPOConfig`` with one shared module and the tested settings.
* :class:`RLlibPolicy`: a trained module (from a checkpoint) as a :class:`baselines.Policy`
  (the policy name ``rllib:CHECKPOINT`` of :func:`baselines.registry.make_policy`).

Needs the ``rllib`` extra (``ray[rllib]``, which pins gymnasium 1.2.2: use its own venv, as
``scripts/run_tests_rllib.sh`` does). Bad arguments exit with code 2 and one ``error: ...``
line; a failure while training exits 1 with one line (``TEAMGYM_TRACEBACK=1`` shows it).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from baselines.policy import Policy

try:  # the env adapter and the masking module are module-level classes (Ray pickles them by reference)
    from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule as _PPOModule
    from ray.rllib.env.multi_agent_env import MultiAgentEnv as _MultiAgentEnv
except ImportError:  # ray[rllib] or torch missing: importing this module still works; using it raises
    _MultiAgentEnv = object  # type: ignore[assignment,misc]
    _PPOModule = object  # type: ignore[assignment,misc]

__all__ = [
    "MODEL_SETTINGS",
    "MODULE_ID",
    "MaskedPPOTorchRLModule",
    "TESTED_SETTINGS",
    "RLlibPolicy",
    "TeamMultiAgentEnv",
    "build_parser",
    "episode_flags",
    "evaluate_checkpoint",
    "main",
    "module_path",
    "ppo_config",
    "read_sidecar",
    "require_rllib",
    "train",
    "with_masks",
]

#: The id of the one RLModule every agent maps to.
MODULE_ID = "shared"
DEFAULT_ENV, DEFAULT_ITERATIONS, DEFAULT_EVAL_SEED = "Navigation-v0", 10, 10_000

#: PPO settings (``PPOConfig.training`` keywords) used unless ``--defaults``: SB3's PPO defaults,
#: which ``baselines.train`` uses, on RLlib's names. See docs/scale_out.md for why and what we measured.
TESTED_SETTINGS: dict[str, Any] = {
    "lr": 3e-4,
    "gamma": 0.99,
    "lambda_": 0.95,
    "train_batch_size_per_learner": 4000,
    "minibatch_size": 250,
    "num_epochs": 10,
    "clip_param": 0.2,
    "use_kl_loss": False,
    "vf_loss_coeff": 0.5,
    "vf_clip_param": math.inf,
    "entropy_coeff": 0.0,
    "grad_clip": 0.5,
}
#: ``DefaultModelConfig`` fields used unless ``--defaults``: separate 64-64 tanh policy and value
#: networks and, for Box actions, a state-independent log-std (SB3's ``MlpPolicy``).
MODEL_SETTINGS: dict[str, Any] = {
    "fcnet_hiddens": [64, 64],
    "fcnet_activation": "tanh",
    "vf_share_layers": False,
    "free_log_std": True,
}

_INSTALL = "pip install 'teamgym[rllib]' in its own venv (ray[rllib] pins gymnasium==1.2.2; see docs/scale_out.md)"


def require_rllib() -> None:
    """Raise ``ImportError`` with the install command if ``ray[rllib]`` (and torch) cannot be imported."""
    for module in ("ray", "ray.rllib", "torch"):
        try:
            found = importlib.util.find_spec(module) is not None
        except ImportError:
            found = False
        if not found:
            raise ImportError(f"the RLlib path needs the {module} package: {_INSTALL}")
    if _MultiAgentEnv is object:
        raise ImportError(f"ray.rllib could not be imported: {_INSTALL}")


def _make_env(env_id: str, config: Mapping[str, Any] | None) -> Any:
    import teamgym

    return teamgym.make(env_id, **dict(config or {}))


def with_masks(observations: Mapping[str, Any], masks: Mapping[str, Any], n_actions: int) -> dict[str, Any]:
    """``{"observations": obs, "action_mask": float32 0/1 row}`` per agent (all ones for an agent without a mask)."""
    ones = np.ones(int(n_actions), dtype=np.float32)
    return {
        a: {"observations": obs, "action_mask": np.asarray(masks[a], dtype=np.float32) if a in masks else ones}
        for a, obs in observations.items()
    }


def episode_flags(terminations: Mapping[str, bool], truncations: Mapping[str, bool], over: bool) -> tuple[dict, dict]:
    """RLlib's per-agent flags of one step plus ``"__all__"`` (see :class:`TeamMultiAgentEnv`'s docstring).

    ``over``: no live agent is left. The episode then ends terminated if no agent was truncated on
    this step, else truncated, and the per-agent truncations are cleared (RLlib infers them from ``"__all__"``).
    """
    truncated = any(truncations.values())
    terminations = {**terminations, "__all__": over and not truncated}
    if over:
        truncations = dict.fromkeys(truncations, False)
    return terminations, {**truncations, "__all__": over and truncated}


class TeamMultiAgentEnv(_MultiAgentEnv):
    """A teamgym ``ParallelEnv`` as an RLlib ``MultiAgentEnv`` for the new API stack.

    Built by RLlib from ``env_config = {"env_id": ..., "config": {...}}`` (what
    :func:`ppo_config` passes), or around an existing env with ``TeamMultiAgentEnv(env=env)``.

    * Observations must be flat (``obs_format="flat"``, the default); actions ``Box`` or
      ``Discrete`` (no ``comm_dim`` message, no MultiDiscrete operators).
    * With a Discrete action type that has masks, each observation is
      ``{"observations": obs, "action_mask": float32 0/1 row}`` (RLlib's action-masking module).
    * The episode ends when the env has no live agents left: ``terminateds["__all__"]`` if no
      agent was truncated on that step, else ``truncateds["__all__"]`` (RLlib's
      ``ParallelPettingZooEnv`` takes ``all()`` over the agents that reported, so both flags are
      ``False`` when the last agents end part terminated, part truncated).
    * Truncation is reported through ``truncateds["__all__"]`` only, with the per-agent
      ``truncateds`` left ``False``. RLlib's ``MultiAgentEpisode`` (2.60) marks every agent
      *terminated* once all agents have reported done, so per-agent truncation flags would make
      PPO treat the time limit as terminal (no value bootstrap); with ``__all__`` alone each
      truncated agent ends truncated and each terminated one terminated.
    """

    def __init__(self, env_config: Mapping[str, Any] | None = None, *, env: Any = None) -> None:
        require_rllib()
        super().__init__()
        if env is None:
            env_config = dict(env_config or {})
            env = _make_env(env_config.get("env_id", DEFAULT_ENV), env_config.get("config"))
        self.env = env
        self.possible_agents = list(env.possible_agents)
        self.agents = []
        first = self.possible_agents[0]
        obs_space, act_space = env.observation_space(first), env.action_space(first)
        where = type(env).__name__
        if not isinstance(obs_space, spaces.Box):
            raise ValueError(f"{where}: RLlib needs flat observations (obs_format='flat'), not {type(obs_space).__name__}")
        if not isinstance(act_space, (spaces.Box, spaces.Discrete)):
            raise ValueError(
                f"{where}: the RLlib adapter takes Box or Discrete actions, not {type(act_space).__name__} "
                "(set comm_dim=0 and a continuous or discrete action_type)"
            )
        for agent in self.possible_agents:
            if env.observation_space(agent) != obs_space or env.action_space(agent) != act_space:
                raise ValueError(f"{where}: agent {agent!r} has other spaces than {first!r}; one shared policy needs equal ones")
        self.masked = bool(getattr(getattr(env, "action_type", None), "has_masks", False))
        if self.masked and not isinstance(act_space, spaces.Discrete):
            raise ValueError(f"{where}: action masks are supported for Discrete actions only, not {act_space}")
        if self.masked:
            mask_space = spaces.Box(0.0, 1.0, shape=(int(act_space.n),), dtype=np.float32)
            obs_space = spaces.Dict({"observations": obs_space, "action_mask": mask_space})
        self.observation_spaces = dict.fromkeys(self.possible_agents, obs_space)
        self.action_spaces = dict.fromkeys(self.possible_agents, act_space)

    def observe(self, observations: dict[str, Any]) -> dict[str, Any]:
        """The observations RLlib sees: the env's, with each live agent's action mask added for masked action types."""
        if not self.masked:
            return observations
        return with_masks(observations, self.env.action_masks(), self.action_spaces[self.possible_agents[0]].n)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        observations, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.env.agents)
        return self.observe(observations), infos

    def step(self, action_dict: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        observations, rewards, terminations, truncations, infos = self.env.step(action_dict)
        self.agents = list(self.env.agents)
        terminations, truncations = episode_flags(terminations, truncations, not self.env.agents)
        return self.observe(observations), rewards, terminations, truncations, infos

    def render(self) -> Any:
        return self.env.render()

    def close(self) -> None:
        self.env.close()


class MaskedPPOTorchRLModule(_PPOModule):
    """RLlib's default PPO torch module for ``Dict(observations=..., action_mask=...)`` observations.

    The networks see ``observations`` only; logits of actions whose mask is 0 are pushed to
    RLlib's ``FLOAT_MIN`` before sampling, in the loss and in inference (as RLlib's
    action-masking example does, on ``DefaultPPOTorchRLModule``).
    """

    def __init__(self, *, observation_space: Any = None, **kwargs: Any) -> None:
        self._space_with_mask = observation_space
        inner = observation_space["observations"] if observation_space is not None else None
        super().__init__(observation_space=inner, **kwargs)

    def setup(self) -> None:
        super().setup()
        self.observation_space = self._space_with_mask

    @staticmethod
    def _split(batch: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        obs = batch["obs"]
        if not isinstance(obs, Mapping):
            return None, batch
        return obs["action_mask"], {**batch, "obs": obs["observations"]}

    @staticmethod
    def _masked(out: dict[str, Any], mask: Any) -> dict[str, Any]:
        if mask is not None:
            import torch
            from ray.rllib.utils.torch_utils import FLOAT_MIN

            out["action_dist_inputs"] = out["action_dist_inputs"] + torch.clamp(torch.log(mask), min=FLOAT_MIN)
        return out

    def _forward(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        mask, batch = self._split(batch)
        return self._masked(super()._forward(batch, **kwargs), mask)

    def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        mask, batch = self._split(batch)
        return self._masked(super()._forward_train(batch, **kwargs), mask)

    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> Any:
        return super().compute_values(self._split(batch)[1], embeddings)


def _policy_mapping(agent_id: Any, episode: Any = None, **kwargs: Any) -> str:
    return MODULE_ID


def ppo_config(
    env_id: str = DEFAULT_ENV,
    config: Mapping[str, Any] | None = None,
    *,
    seed: int = 0,
    training: Mapping[str, Any] | None = None,
    model: Mapping[str, Any] | None = None,
    num_env_runners: int = 0,
    rllib_defaults: bool = False,
    envs_per_runner: int = 1,
) -> Any:
    """A ``PPOConfig`` that trains one module (:data:`MODULE_ID`) shared by every robot of ``env_id``.

    ``training`` and ``model`` update :data:`TESTED_SETTINGS` and :data:`MODEL_SETTINGS` (or RLlib's
    defaults with ``rllib_defaults``). ``num_env_runners=0`` samples in the driver process. The env
    is built once here, so a bad id, config or space fails before Ray starts anything.
    ``envs_per_runner > 1``: each env runner steps that many copies as one ``teamgym.make_batch``
    batch (:class:`baselines.rl.rllib_batch.TeamBatchEnvRunner`) instead of RLlib's loop over copies.
    """
    if not isinstance(envs_per_runner, int) or isinstance(envs_per_runner, bool) or envs_per_runner < 1:
        raise ValueError(f"envs_per_runner must be an integer >= 1, got {envs_per_runner!r}")
    require_rllib()
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    probe = TeamMultiAgentEnv({"env_id": env_id, "config": dict(config or {})})
    masked, continuous = probe.masked, isinstance(probe.action_spaces[probe.possible_agents[0]], spaces.Box)
    probe.close()
    settings, model_settings = _settings(training, model, rllib_defaults, continuous)
    runner: dict[str, Any] = {}
    if envs_per_runner > 1:
        from baselines.rl.rllib_batch import TeamBatchEnvRunner

        runner["env_runner_cls"] = TeamBatchEnvRunner
    spec = RLModuleSpec(
        module_class=MaskedPPOTorchRLModule if masked else None, model_config=DefaultModelConfig(**model_settings)
    )
    return (
        PPOConfig()
        # RLlib's env checker steps random actions, which a masked env rejects.
        .environment(TeamMultiAgentEnv, env_config={"env_id": env_id, "config": dict(config or {})}, disable_env_checking=masked)
        .framework("torch")
        .env_runners(num_env_runners=num_env_runners, num_envs_per_env_runner=envs_per_runner, **runner)
        .multi_agent(policies={MODULE_ID}, policy_mapping_fn=_policy_mapping)
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={MODULE_ID: spec}))
        .training(**settings)
        .debugging(seed=seed)
    )


def _settings(
    training: Mapping[str, Any] | None, model: Mapping[str, Any] | None, rllib_defaults: bool, continuous: bool
) -> tuple[dict[str, Any], dict[str, Any]]:
    """PPO ``training`` keywords and ``DefaultModelConfig`` fields: the tested ones (or none) updated with the given."""
    settings = {} if rllib_defaults else dict(TESTED_SETTINGS)
    settings.update(training or {})
    model_settings = {} if rllib_defaults else dict(MODEL_SETTINGS)
    if not continuous:  # RLlib: a free log-std exists for Gaussian (Box) actions only
        model_settings.pop("free_log_std", None)
    model_settings.update(model or {})
    return settings, model_settings


def module_path(checkpoint: str | Path) -> Path:
    """The shared module's directory inside an algorithm checkpoint (or ``checkpoint`` itself if it is one)."""
    path = Path(checkpoint)
    inner = path / "learner_group" / "learner" / "rl_module" / MODULE_ID
    if inner.is_dir():
        return inner
    if (path / "module_state.pkl").is_file() or (path / "module_state.pt").is_file():
        return path
    raise FileNotFoundError(f"no RLlib checkpoint with a {MODULE_ID!r} module at {str(path)!r}")


class RLlibPolicy(Policy):
    """A shared RLlib module (from :func:`train`'s checkpoint) acting for every robot of ``env``.

    The live agents' observations are stacked into one ``forward_inference`` batch; actions are
    the distribution's mode (``deterministic``) or samples (seeded through torch by :meth:`reset`),
    mapped to the action space as RLlib's env runner does (Box: unsquashed from [-1, 1], clipped).
    """

    name = "rllib"

    @classmethod
    def load(cls, checkpoint: str | Path, env: Any, deterministic: bool = True) -> RLlibPolicy:
        """The policy of the checkpoint directory ``checkpoint`` for ``env`` (what ``rllib:CHECKPOINT`` builds)."""
        return cls(env, checkpoint, deterministic=deterministic)

    def __init__(self, env: Any, checkpoint: str | Path, deterministic: bool = True) -> None:
        super().__init__(env)
        require_rllib()
        import torch
        from ray.rllib.core.rl_module.rl_module import RLModule

        self._torch = torch
        self.adapter = TeamMultiAgentEnv(env=env)
        self.module = RLModule.from_checkpoint(module_path(checkpoint))
        self.deterministic = deterministic
        first = env.possible_agents[0]
        expected, got = self.adapter.observation_spaces[first], self.module.observation_space
        if got is not None and got != expected:
            raise ValueError(f"the module at {str(checkpoint)!r} takes observations {got}, the env gives {expected}")
        self.action_space = self.adapter.action_spaces[first]
        if self.module.action_space is not None and self.module.action_space != self.action_space:
            raise ValueError(
                f"the module at {str(checkpoint)!r} acts in {self.module.action_space}, the env in {self.action_space}"
            )

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        if seed is not None and not self.deterministic:
            self._torch.manual_seed(seed)

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        torch = self._torch
        agents = list(observations)
        if not agents:
            return {}
        rows = self.adapter.observe(observations)
        if self.adapter.masked:
            obs: Any = {key: torch.as_tensor(np.stack([rows[a][key] for a in agents])) for key in ("observations", "action_mask")}
        else:
            obs = torch.as_tensor(np.stack([rows[a] for a in agents]))
        with torch.no_grad():
            out = self.module.forward_inference({"obs": obs})
            dist = self.module.get_inference_action_dist_cls().from_logits(out["action_dist_inputs"])
            if self.deterministic:
                dist = dist.to_deterministic()
            actions = dist.sample().numpy()
        space = self.action_space
        if isinstance(space, spaces.Box):
            actions = np.clip(space.low + (actions + 1.0) * (space.high - space.low) / 2.0, space.low, space.high)
            return {a: actions[i].astype(space.dtype) for i, a in enumerate(agents)}
        return {a: int(actions[i]) for i, a in enumerate(agents)}


def _number(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _iteration_row(iteration: int, result: Mapping[str, Any], seconds: float) -> dict[str, Any]:
    """The numbers of one ``algo.train()`` result worth keeping (NaN where RLlib reported none)."""
    runners = result.get("env_runners") or {}
    learner = (result.get("learners") or {}).get(MODULE_ID) or {}
    agent_steps = runners.get("num_agent_steps_sampled_lifetime") or {}
    return {
        "iteration": iteration,
        "env_steps": _number(result.get("num_env_steps_sampled_lifetime")),
        "agent_steps": float(sum(agent_steps.values())) if isinstance(agent_steps, Mapping) else _number(agent_steps),
        "episodes": _number(runners.get("num_episodes_lifetime", runners.get("num_episodes"))),
        "episode_return_mean": _number(runners.get("episode_return_mean")),
        "episode_len_mean": _number(runners.get("episode_len_mean")),
        "vf_explained_var": _number(learner.get("vf_explained_var")),
        "vf_loss_unclipped": _number(learner.get("vf_loss_unclipped")),
        "entropy": _number(learner.get("entropy")),
        "seconds": round(seconds, 2),
    }


def evaluate_checkpoint(
    checkpoint: str | Path,
    env_id: str = DEFAULT_ENV,
    config: Mapping[str, Any] | None = None,
    episodes: int = 10,
    seed: int = DEFAULT_EVAL_SEED,
    deterministic: bool = True,
) -> list[Any]:
    """Play ``episodes`` episodes (seeds ``seed ..``) with the checkpoint's shared module; ``EpisodeResult`` per episode.

    This is :func:`baselines.evaluate.evaluate` of the policy ``rllib:CHECKPOINT`` in this process, so
    :func:`baselines.summary.summarise` applies.
    """
    from baselines.evaluate import evaluate

    policy_kwargs = {"deterministic": deterministic}
    return evaluate(env_id, f"rllib:{checkpoint}", episodes, seed, dict(config or {}), policy_kwargs=policy_kwargs)


def _init_ray(num_cpus: int | None, address: str | None = None) -> bool:
    """Start a local Ray session (``num_cpus``) or connect to the cluster at ``address``, unless a session runs.

    ``True`` if this call started or connected the session (``ray.init``; ``RAY_ADDRESS`` applies when neither is given).
    """
    import logging

    import ray

    if ray.is_initialized():
        return False
    if address is not None:
        ray.init(address=address, logging_level=logging.WARNING)
    else:
        ray.init(num_cpus=num_cpus, include_dashboard=False, logging_level=logging.WARNING)
    return True


def _node_id(env_runner: Any) -> str:
    """The id of the Ray node an env runner runs on (called on each remote env runner)."""
    import ray

    return ray.get_runtime_context().get_node_id()


def train(
    env_id: str = DEFAULT_ENV,
    iterations: int = DEFAULT_ITERATIONS,
    *,
    config: Mapping[str, Any] | None = None,
    out: str | Path | None = None,
    seed: int = 0,
    training: Mapping[str, Any] | None = None,
    model: Mapping[str, Any] | None = None,
    num_env_runners: int = 0,
    num_cpus: int | None = None,
    ray_address: str | None = None,
    rllib_defaults: bool = False,
    on_iteration: Callable[[dict[str, Any]], None] | None = None,
    envs_per_runner: int = 1,
) -> Path:
    """Train PPO with one shared module for ``iterations`` iterations; save the checkpoint to ``out``.

    Unless a Ray session is running, starts a local one with ``num_cpus`` CPUs or connects to the
    cluster at ``ray_address`` (``HOST:PORT`` of its head; not with ``num_cpus``), and ends it
    after. The ``num_env_runners`` env runners (one CPU each) go wherever the cluster has room; the
    learner runs in this process. Each env runner (or this process) steps ``envs_per_runner``
    copies, as one batch when more than one (see :func:`ppo_config`). ``out`` (default ``results/rllib/<env>_ppo``) gets RLlib's
    checkpoint and ``teamgym.json``: env id, config, settings, the Ray node of each env runner
    (``env_runner_nodes``) and one row per iteration (see :func:`_iteration_row`);
    ``on_iteration(row)`` is called after each. Returns ``out``.
    """
    require_rllib()
    if ray_address is not None:
        import ray

        from baselines.runners import check_ray_address

        check_ray_address(ray_address)
        if num_cpus is not None:
            raise ValueError("num_cpus sizes a new local Ray cluster; it cannot be given with ray_address")
        if ray.is_initialized():
            raise ValueError("ray_address was given, but this process already runs a Ray session (it would be used)")
    out = Path(out) if out is not None else Path("results") / "rllib" / f"{env_id}_ppo"
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r} is an existing file, not a directory")
    probe = _make_env(env_id, config)  # the resolved config, for the sidecar
    resolved = probe.config.as_dict() if hasattr(probe.config, "as_dict") else dict(config or {})
    probe.close()
    algo_config = ppo_config(
        env_id,
        config,
        seed=seed,
        training=training,
        model=model,
        num_env_runners=num_env_runners,
        rllib_defaults=rllib_defaults,
        envs_per_runner=envs_per_runner,
    )
    started = _init_ray(num_cpus, ray_address)
    try:
        algo = algo_config.build_algo()
        try:
            nodes = algo.env_runner_group.foreach_env_runner(_node_id, local_env_runner=False) if num_env_runners else []
            rows = []
            for i in range(iterations):
                begin = time.perf_counter()
                row = _iteration_row(i + 1, algo.train(), time.perf_counter() - begin)
                rows.append(row)
                if on_iteration is not None:
                    on_iteration(row)
            out.mkdir(parents=True, exist_ok=True)
            algo.save_to_path(str(out.resolve()))
        finally:
            algo.stop()
    finally:
        if started:
            import ray

            ray.shutdown()
    training_settings = {key: getattr(algo_config, key, None) for key in {**TESTED_SETTINGS, **dict(training or {})}}
    model_config = algo_config.rl_module_spec.rl_module_specs[MODULE_ID].model_config
    model_config = model_config if isinstance(model_config, dict) else dataclasses.asdict(model_config)
    model_settings = {key: model_config.get(key) for key in {**MODEL_SETTINGS, **dict(model or {})}}
    sidecar = {
        "env": env_id,
        "overrides": {k: str(v) for k, v in dict(config or {}).items()},
        "config": resolved,
        "algo": "ppo",
        "module_id": MODULE_ID,
        "seed": seed,
        "iterations": iterations,
        "rllib_defaults": rllib_defaults,
        "training": training_settings,
        "model": model_settings,
        "num_env_runners": num_env_runners,
        "envs_per_runner": envs_per_runner,
        "env_runner_nodes": nodes,
        "history": rows,
    }
    _write_sidecar(out, sidecar)
    return out


def _write_sidecar(out: Path, data: Mapping[str, Any]) -> Path:
    from baselines.learned import sidecar_path, write_sidecar

    return write_sidecar(sidecar_path("rllib", out), "rllib", data)


def read_sidecar(checkpoint: str | Path) -> dict[str, Any]:
    """The sidecar ``teamgym.json`` of a checkpoint in the format of :mod:`baselines.learned` (``{}`` if there is none).

    A file written before that format (its ``config`` held the given settings) reads the same as a new
    one (they are its ``overrides``); a field of the wrong type is a ``ValueError`` naming the file and field.
    """
    from baselines.learned import read_sidecar as read

    return read("rllib", checkpoint) or {}


# -- command line -----------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.rl.rllib`` argument parser (a bad command line exits 2 with a one-line error)."""
    from baselines.cli import Parser, at_least, cluster_address, nonblank

    parser = Parser(
        prog="python -m baselines.rl.rllib",
        description="Train one shared PPO policy on a teamgym env with Ray RLlib (new API stack).",
    )
    count, natural = at_least(1), at_least(0)
    parser.add_argument(
        "--env",
        type=nonblank("an env id"),
        default=None,
        help=f"env id (default: {DEFAULT_ENV}; with --evaluate: the checkpoint's)",
    )
    parser.add_argument(
        "--iterations", type=natural, default=DEFAULT_ITERATIONS, help=f"PPO iterations (default: {DEFAULT_ITERATIONS})"
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config override (repeatable)")
    parser.add_argument(
        "--hp", action="append", default=[], metavar="KEY=VALUE", help="PPOConfig.training keyword, e.g. lr=1e-4 (repeatable)"
    )
    parser.add_argument("--defaults", action="store_true", help="start from RLlib's PPO defaults, not the tested settings")
    parser.add_argument("--seed", type=natural, default=0, help="random seed (default: 0)")
    parser.add_argument(
        "--out", type=nonblank("a directory"), default=None, help="checkpoint directory (default: results/rllib/<env>_ppo)"
    )
    parser.add_argument("--env-runners", type=natural, default=0, help="remote env runners; 0 samples in this process (default)")
    parser.add_argument(
        "--envs-per-runner",
        type=count,
        default=1,
        metavar="K",
        help="env copies per env runner, stepped as one teamgym.make_batch batch when K > 1 (default: 1)",
    )
    cluster = parser.add_mutually_exclusive_group()
    cluster.add_argument("--num-cpus", type=count, default=None, help="CPUs of the local Ray cluster (default: all)")
    cluster.add_argument(
        "--ray-address",
        type=cluster_address,
        default=None,
        metavar="ADDR",
        help="train on the existing Ray cluster whose head is HOST:PORT (default: RAY_ADDRESS, else a new local one)",
    )
    parser.add_argument("--threads", type=count, default=1, help="torch CPU threads of this process (default: 1)")
    parser.add_argument(
        "--eval-episodes", type=natural, default=0, help="after training, evaluate greedily on K held-out episodes (default: 0)"
    )
    parser.add_argument(
        "--eval-seed", type=natural, default=DEFAULT_EVAL_SEED, help=f"first held-out seed (default: {DEFAULT_EVAL_SEED})"
    )
    parser.add_argument(
        "--evaluate",
        type=nonblank("a checkpoint"),
        default=None,
        metavar="CHECKPOINT",
        help="evaluate a saved checkpoint instead of training",
    )
    return parser


def _training_keywords(pairs: Mapping[str, str]) -> dict[str, Any]:
    """``--hp`` values parsed; ``ValueError`` for a key that ``PPOConfig.training`` does not take."""
    import inspect

    from ray.rllib.algorithms.ppo import PPOConfig

    from teamgym.envs.config import parse_value

    accepted = {
        name for cls in PPOConfig.__mro__ if "training" in vars(cls) for name in inspect.signature(cls.training).parameters
    } - {"self", "kwargs"}
    for key in pairs:
        if key not in accepted:
            raise ValueError(f"--hp {key!r} is not a PPOConfig.training keyword (e.g. lr, num_epochs, minibatch_size)")
    return {key: parse_value(value) for key, value in pairs.items()}


def _report(summary: Mapping[str, Any], title: str) -> None:
    from baselines.summary import summary_table

    print(summary_table(summary, title=title))


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (2: bad arguments or missing ray[rllib]; 1: failure while training)."""
    from baselines.cli import guarded, message, parse_args, parse_pairs
    from baselines.summary import summarise

    args = parse_args(build_parser(), argv)
    if isinstance(args, int):
        return args
    try:
        require_rllib()
        config: dict[str, Any] = parse_pairs(args.set, "--set")
        training = _training_keywords(parse_pairs(args.hp, "--hp"))
        if args.evaluate is not None:
            if args.ray_address is not None:
                raise ValueError("--ray-address applies to training; --evaluate plays its episodes in this process")
            module_path(args.evaluate)  # FileNotFoundError: one line
            saved = read_sidecar(args.evaluate)
            env_id = args.env if args.env is not None else saved.get("env") or DEFAULT_ENV
            if env_id == saved.get("env"):
                config = {**saved.get("overrides", {}), **config}
            import teamgym

            teamgym.make(env_id, **config).close()  # a bad id or config fails here, in one line
        else:
            env_id = DEFAULT_ENV if args.env is None else args.env
    except (ValueError, TypeError, KeyError, FileNotFoundError, ImportError) as error:
        print(f"error: {message(error)}", file=sys.stderr)
        return 2
    import torch

    torch.set_num_threads(args.threads)

    def work() -> int:
        try:
            if args.evaluate is not None:
                checkpoint = Path(args.evaluate)
                episodes = args.eval_episodes or 10
            else:

                def show(row: Mapping[str, Any]) -> None:
                    print(
                        f"iteration {row['iteration']}: env steps {row['env_steps']:.0f}, episodes {row['episodes']:.0f}, "
                        f"return {row['episode_return_mean']:.3g}, vf explained var {row['vf_explained_var']:.3g}, "
                        f"{row['seconds']:.1f} s",
                        flush=True,
                    )

                checkpoint = train(
                    env_id,
                    args.iterations,
                    config=config,
                    out=args.out,
                    seed=args.seed,
                    training=training,
                    num_env_runners=args.env_runners,
                    num_cpus=args.num_cpus,
                    ray_address=args.ray_address,
                    rllib_defaults=args.defaults,
                    on_iteration=show,
                    envs_per_runner=args.envs_per_runner,
                )
                print(f"saved {checkpoint} (settings and per-iteration results in {checkpoint / 'teamgym.json'})")
                episodes = args.eval_episodes
            if episodes:
                results = evaluate_checkpoint(checkpoint, env_id, config, episodes, args.eval_seed)
                summary = summarise(results)
                last = args.eval_seed + episodes - 1
                _report(summary, f"{env_id} | rllib:{checkpoint} | {episodes} episodes (seeds {args.eval_seed}-{last})")
                if args.evaluate is None:
                    data = read_sidecar(checkpoint)
                    data["eval"] = {"seed": args.eval_seed, "episodes": episodes, **summary}
                    _write_sidecar(checkpoint, data)
        except (ValueError, FileNotFoundError) as error:
            print(f"error: {message(error)}", file=sys.stderr)
            return 2
        return 0

    return guarded(work)


if __name__ == "__main__":
    # Re-enter through the importable module so Ray pickles TeamMultiAgentEnv by reference.
    from baselines.rl.rllib import main as _main

    sys.exit(_main())
