"""Train one parameter-shared Stable-Baselines3 model for every robot of a teamgym env.

Command line::

    python -m baselines.train [--env Navigation-v0] [--algo ppo] [--timesteps 100000] [--seed 0]
        [--out results/models/<env>_<algo>.zip] [--set key=value ...] [--max-cycles M]
        [--n-envs 4] [--hp key=value ...] [--verbose 0|1|2] [--threads 1]
        [--tensorboard DIR] [--progress-bar] [--checkpoint-every N] [--resume PATH]
        [--eval-every N] [--eval-episodes 10] [--eval-seed 10000]
        [--seeds 0,1,2] [--jobs 1] [--bc-expert NAME] [--bc-steps 20000] [--bc-epochs 30]
        [--bc-noise 0.5] [--bc-batch-size 64] [--bc-lr 1e-3] [--bc-std-fraction 0.2]
        [--bc-label-smoothing 0.1] [--bc-no-value] [--bc-dagger-steps N] [--bc-dagger-epochs K]
        [--message-levels 5] [--message-tokens 8] [--message-vocab 64]
        [--critic local|central] [--agent-id] [--independent] [--net mlp|cells]

Timesteps count agent transitions (every robot's step is one SB3 step, see
:class:`baselines.rl.sb3_env.TeamVecEnv`). The model is saved to ``--out`` and a sidecar
``<out>.json`` records the env id, its config, the algorithm and the training settings.
Evaluate it with ``python -m baselines.evaluate --policy sb3:PATH`` (the env and config come
from the sidecar). DQN needs a discrete action space (``--set action_type=heading``);
SAC/TD3/DDPG need a continuous one.

Research tooling (all off by default; see ``docs/training.md``):

* ``--tensorboard DIR``: SB3's TensorBoard logs in ``DIR/<run>_<k>`` (``<run>`` is the
  model's file stem, ``seed<k>`` with ``--seeds``); ``--progress-bar``: SB3's progress bar.
* ``--checkpoint-every N``: save ``<out-stem>_<steps>_steps.zip`` (with its sidecar) at the
  first rollout boundary at or past each multiple of ``N`` timesteps (and at the end if
  the last rollout crossed one): the model trained on exactly ``<steps>`` transitions.
* ``--resume PATH``: continue training a saved model for ``--timesteps`` more timesteps
  (``reset_num_timesteps=False``: the counter, the TensorBoard curve, the checkpoint and
  evaluation schedules and the eval CSV continue). Env, config, algorithm, ``--n-envs``,
  seed, TensorBoard, checkpoint and evaluation settings come from the model's sidecar
  unless given. ``--out`` defaults to the model resumed, or for a checkpoint
  ``<stem>_<steps>_steps.zip`` or ``<stem>_best.zip`` to ``<stem>.zip``.
* ``--eval-every N``: evaluate the model on the held-out seeds ``S .. S+K-1``
  (``--eval-seed S``, ``--eval-episodes K``) at the start, at the first rollout boundary
  past each multiple of ``N`` and at the end, through the episode loop of ``baselines.evaluate``
  (:func:`baselines.rl.callbacks.evaluate_model`); rows go to ``<out-stem>_eval.csv`` and
  to TensorBoard (``eval/...``), and the best model so far (success rate, then mean return)
  to ``<out-stem>_best.zip``.
* ``--seeds 0,1,2``: one model per seed in ``<out>/seed<k>/<env>_<algo>.zip`` (``--out`` is
  then a directory, default ``results/models/<env>_<algo>/``), one after the other or in
  ``--jobs`` processes; ``<out>/runs.json`` lists them.
* ``--bc-expert NAME``: before training, behaviour-clone the scripted policy ``NAME``
  (``--bc-steps`` expert transitions, ``--bc-epochs`` passes; PPO, A2C, MaskablePPO, and the
  recurrent algorithms on each robot's episode as a sequence, :mod:`baselines.rl.recurrent_imitation`)
  into the new model, value head included (:func:`baselines.rl.imitation.pretrain`); ``--bc-dagger R``
  adds R rounds of DAgger (the clone drives, the expert labels, the clone is refitted on
  all data); a preset's ``bc.expert_kwargs`` are the expert's constructor arguments; the
  sidecar's ``bc`` records the settings and the expert's and the clone's success on the
  collected episodes. ``--bc-noise`` (DART noise of the executed expert actions, default 0.5;
  0: the expert's own episodes), ``--bc-batch-size``, ``--bc-lr``, ``--bc-std-fraction``,
  ``--bc-label-smoothing``, ``--bc-no-value``, ``--bc-dagger-steps`` and ``--bc-dagger-epochs``
  set the rest of :func:`baselines.rl.imitation.pretrain`'s settings (a preset's ``bc`` otherwise).
* ``--algo recurrent-ppo``: sb3-contrib's ``RecurrentPPO`` (LSTM); evaluation carries each
  robot's hidden state through the episode (:mod:`baselines.rl.recurrent`); on masked action types
  it is refused (sb3-contrib has no masked RecurrentPPO) and ``--algo maskable-recurrent-ppo``
  is the masked variant (:mod:`baselines.rl.masked_recurrent`).
* A motion ⊕ message action (``--set comm_dim=K``, Rendezvous' ``protocol_messages=True``) is
  trained as one flat Box or MultiDiscrete action (:mod:`baselines.rl.message_actions`;
  ``--message-levels``, ``--message-tokens``, ``--message-vocab``); the sidecar's
  ``message_actions`` lets ``baselines.evaluate`` decode it.
* ``--critic central``: a centralised critic (MAPPO-style): each robot's observation carries the
  team ``state()``, which only the critic reads (:mod:`baselines.rl.central_critic`);
  ``--agent-id``: a one-hot of the robot's index in its observation; ``--independent``: one
  policy per robot, no shared parameters, stored in one zip (:mod:`baselines.rl.independent`).
  The sidecar records them (``obs_features``) and ``sb3:PATH`` evaluation widens the
  observations the same way (:mod:`baselines.rl.agent_features`, :mod:`baselines.rl.team_methods`).
* ``--net cells``: a go-to-cell action (Foraging-v0's ``goto_cell``) scored cell by cell over the
  observation's grid layers (:mod:`baselines.rl.cell_policy`) instead of an MLP over the flat
  observation; the policy class is saved in the zip.

Bad arguments exit with code 2 and one ``error: ...`` line before training starts (``--hp``
values and a preset's hyperparameters before any env is built: :mod:`baselines.rl.hyperparameters`;
an ``--out`` that cannot be written before anything runs); any other failure exits 1 with one
line (``TEAMGYM_TRACEBACK=1`` shows the traceback).
Ctrl-C saves the model trained so far to ``--out`` (its sidecar says ``"interrupted": true``).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import re
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from baselines.rl.imitation import DEFAULT_BC_EPOCHS, DEFAULT_BC_NOISE, DEFAULT_BC_STEPS
from baselines.rl.recurrent import MASKED_RECURRENT, RECURRENT_ALGORITHMS

__all__ = ["DEFAULT_EVAL_SEED", "Training", "build_parser", "default_hyperparameters", "main", "train", "train_seeds"]

#: The first held-out evaluation seed: far from the training envs' reset seeds ``seed + e·A``.
DEFAULT_EVAL_SEED = 10_000
DEFAULT_ENV, DEFAULT_ALGO, DEFAULT_N_ENVS, DEFAULT_EVAL_EPISODES = "Navigation-v0", "ppo", 4, 10


def default_hyperparameters(algo: str, num_envs: int) -> dict[str, Any]:
    """Modest defaults: on-policy rollouts of ~2048 transitions in 8 equal mini-batches."""
    from baselines.rl.sb3_policy import algorithm_name

    algo = algorithm_name(algo)
    if algo in ("ppo", "maskable_ppo", "recurrent_ppo", "maskable_recurrent_ppo"):
        n_steps = max(8, math.ceil(2048 / num_envs / 8) * 8)
        return {"n_steps": n_steps, "batch_size": n_steps * num_envs // 8}
    if algo == "a2c":
        return {"n_steps": 8}
    return {}


def _zip_path(path: str | Path) -> Path:
    path = Path(path)
    return path if path.suffix == ".zip" else path.with_name(path.name + ".zip")


#: The actor's parameters in an SB3 actor-critic policy (what ``--init`` copies into a central-critic run).
ACTOR_KEYS = ("mlp_extractor.policy_net.", "action_net.", "log_std")


def load_weights(model: Any, path: str | Path, cls: Any) -> str:
    """Copy the policy weights of the model saved at ``path`` into ``model``; returns ``"all"`` or ``"actor"``.

    ``--init``: a new run (its own seed, hyper-parameters, env config and timestep counter)
    that starts from another run's network, e.g. an agent trained in another situation of
    the same env. With the same observation and action shapes (their bounds may differ)
    every weight is copied (``"all"``); into a centralised-critic run (``--critic central``,
    whose observation appends the team state) whose actor reads exactly the saved model's
    observation, only the actor is copied (``"actor"``) and the critic starts afresh.
    ``ValueError`` naming what differs otherwise.
    """
    try:
        source = cls.load(str(path), device="cpu")
    except Exception as error:  # noqa: BLE001 - a damaged or foreign file: one clear message
        raise ValueError(f"cannot load {str(path)!r} as a {cls.__name__} model for --init: {error}") from None

    def fits(name: str) -> bool:
        mine, theirs = getattr(model, name), getattr(source, name)
        same = (getattr(mine, "shape", None), getattr(mine, "n", None)) == (
            getattr(theirs, "shape", None),
            getattr(theirs, "n", None),
        )
        return type(mine) is type(theirs) and same

    if not fits("action_space"):
        raise ValueError(
            f"--init {str(path)!r}: its action_space {source.action_space} does not fit this run's {model.action_space}"
        )
    actor_dim = getattr(model.policy, "actor_dim", None)
    if fits("observation_space"):
        state, strict, copied = source.policy.state_dict(), True, "all"
    elif actor_dim is not None and (actor_dim,) == source.observation_space.shape:
        state = {k: v for k, v in source.policy.state_dict().items() if k.startswith(ACTOR_KEYS)}
        strict, copied = False, "actor"
    else:
        theirs, mine = source.observation_space, model.observation_space
        raise ValueError(f"--init {str(path)!r}: its observation_space {theirs} does not fit this run's {mine}")
    try:
        missing, _ = model.policy.load_state_dict(state, strict=strict)
    except RuntimeError as error:  # other layer sizes (net_arch) or another policy class
        raise ValueError(f"--init {str(path)!r}: its network does not fit this run's policy: {error}") from None
    if copied == "actor" and any(k.startswith(ACTOR_KEYS) for k in missing):
        raise ValueError(f"--init {str(path)!r}: its actor does not fit this run's policy (missing {sorted(missing)[:3]})")
    return copied


def checkpoint_path(out: str | Path, timesteps: int) -> Path:
    """``<out-stem>_<timesteps>_steps.zip`` beside ``out``."""
    out = _zip_path(out)
    return out.with_name(f"{out.stem}_{int(timesteps)}_steps.zip")


def best_path(out: str | Path) -> Path:
    """``<out-stem>_best.zip`` beside ``out``: the best model of the periodic evaluations."""
    out = _zip_path(out)
    return out.with_name(f"{out.stem}_best.zip")


def eval_csv_path(out: str | Path) -> Path:
    """``<out-stem>_eval.csv`` beside ``out``: the rows of the periodic evaluations."""
    out = _zip_path(out)
    return out.with_name(f"{out.stem}_eval.csv")


def continued_path(resume: str | Path) -> Path:
    """Default ``--out`` of a resumed run: ``<stem>.zip`` for ``<stem>_<N>_steps.zip`` or ``<stem>_best.zip``, else ``resume``."""
    resume = _zip_path(resume)
    match = re.fullmatch(r"(.+)_(\d+_steps|best)", resume.stem)
    return resume.with_name(f"{match.group(1)}.zip") if match else resume


def _require(module: str, what: str) -> None:
    if importlib.util.find_spec(module) is None:
        raise ImportError(f"{what} needs the {module} package (pip install {module}, or the 'train' extra of teamgym)")


def _saved_hyperparameters(sidecar: Mapping[str, Any]) -> dict[str, Any]:
    """The hyperparameters a sidecar records (as ``repr`` strings), parsed back where they are literals."""
    from teamgym.envs.config import parse_value

    saved = sidecar.get("hyperparameters")
    return {str(k): parse_value(v) if isinstance(v, str) else v for k, v in (saved if isinstance(saved, dict) else {}).items()}


def _write_json(path: Path, data: Mapping[str, Any]) -> Path:
    from baselines.summary import write_json

    return write_json(path, data, default=repr)


def _team_methods(
    critic: str | None, agent_id: bool | None, independent: bool | None, net: str | None, saved: Mapping[str, Any] | None
) -> Any:
    """The run's :class:`~baselines.rl.team_methods.TeamMethods`: as given, or a resumed model's (other choices refused)."""
    from baselines.rl.team_methods import TeamMethods

    given = TeamMethods(critic or "local", bool(agent_id), bool(independent), net or "mlp")
    if saved is None:
        return given
    before = TeamMethods.from_sidecar(saved)
    for name, value in (("critic", critic), ("agent_id", agent_id), ("independent", independent), ("net", net)):
        if value is not None and value != getattr(before, name):
            raise ValueError(f"the resumed model was trained with {name}={getattr(before, name)!r}, not {value!r}")
    return before


class Training:
    """One training run, built and checked in the constructor, run by :meth:`learn`.

    The constructor validates everything (env id and config, algorithm and
    hyperparameters, the model to resume, the evaluation seeds) and builds the envs and
    the model, raising ``ValueError``/``TypeError``/``KeyError``/``FileNotFoundError``/
    ``ImportError`` before any training; :meth:`close` releases the envs of a run that is
    not learned. Arguments are those of :func:`train`.
    """

    def __init__(
        self,
        env_id: str = DEFAULT_ENV,
        algo: str = DEFAULT_ALGO,
        timesteps: int = 100_000,
        seed: int = 0,
        out: str | Path = "model.zip",
        config: Mapping[str, Any] | None = None,
        n_envs: int = DEFAULT_N_ENVS,
        hyperparameters: Mapping[str, Any] | None = None,
        verbose: int = 0,
        threads: int | None = 1,
        *,
        tensorboard_log: str | Path | None = None,
        tb_log_name: str | None = None,
        progress_bar: bool = False,
        checkpoint_every: int | None = None,
        eval_every: int | None = None,
        eval_episodes: int = DEFAULT_EVAL_EPISODES,
        eval_seed: int = DEFAULT_EVAL_SEED,
        resume: str | Path | None = None,
        callback: Any = None,
        bc_expert: str | None = None,
        bc_steps: int = DEFAULT_BC_STEPS,
        bc_epochs: int = DEFAULT_BC_EPOCHS,
        bc_dagger: int = 0,
        bc_dagger_steps: int | None = None,
        bc_dagger_epochs: int | None = None,
        bc_batch_size: int | None = None,
        bc_noise: float | None = None,
        bc_expert_kwargs: Mapping[str, Any] | None = None,
        bc_learning_rate: float | None = None,
        bc_std_fraction: float | None = None,
        bc_label_smoothing: float | None = None,
        bc_fit_value: bool | None = None,
        workers: int = 1,
        preset: str | None = None,
        message_levels: int | None = None,
        message_tokens: int | None = None,
        message_vocab: int | None = None,
        critic: str | None = None,
        agent_id: bool | None = None,
        independent: bool | None = None,
        init: str | Path | None = None,
        net: str | None = None,
    ) -> None:
        import teamgym
        from baselines.rl.callbacks import EvalLog, PaddingShareLog
        from baselines.rl.hyperparameters import check_hyperparameters, check_rollout
        from baselines.rl.message_actions import FlatMessageActions, MessageCodec, MessageSettings, is_message_space
        from baselines.rl.sb3_policy import (
            algorithm_class,
            algorithm_name,
            check_action_space,
            check_masks,
            detect_algorithm,
            read_sidecar,
            resolve_model,
        )

        for name, value, minimum in [("timesteps", timesteps, 1), ("n_envs", n_envs, 1), ("seed", seed, 0)]:
            if value < minimum:
                raise ValueError(f"{name} must be >= {minimum}, got {value}")
        for name, value in [("checkpoint_every", checkpoint_every), ("eval_every", eval_every)]:
            if value is not None and value < 1:
                raise ValueError(f"{name} must be >= 1 (or None: off), got {value}")
        if eval_every and (eval_episodes < 1 or eval_seed < 0):
            raise ValueError(f"eval_episodes must be >= 1 and eval_seed >= 0, got {eval_episodes} and {eval_seed}")
        self.env_id, self.timesteps, self.seed, self.n_envs = env_id, int(timesteps), int(seed), int(n_envs)
        self.config = dict(config or {})
        self.out = _zip_path(out)
        self.checkpoint_every, self.eval_every = checkpoint_every or None, eval_every or None
        self.eval_episodes, self.eval_seed = int(eval_episodes), int(eval_seed)
        self.progress_bar, self.callback = progress_bar, callback
        self.tensorboard_log = str(tensorboard_log) if tensorboard_log is not None else None
        self.tb_log_name = tb_log_name or self.out.stem
        self.resume = resolve_model(resume) if resume is not None else None
        if init is not None and resume is not None:
            raise ValueError("--init starts a new model from saved weights; it cannot be combined with --resume")
        self.init = resolve_model(init) if init is not None else None
        self.init_copied: str | None = None
        previous = (read_sidecar(self.resume) or {}) if self.resume else {}
        if self.resume:
            detected = detect_algorithm(self.resume)
            if detected and detected != algorithm_name(algo):
                raise ValueError(f"the model {str(self.resume)!r} was trained with {detected}, not {algorithm_name(algo)}")
        self.algo = algorithm_name(algo)
        cls = algorithm_class(self.algo)
        resumed_hp = _saved_hyperparameters(previous) if self.resume else {}
        check_hyperparameters(self.algo, hyperparameters or {}, resumed_hp)  # before any env: keys, types and ranges
        hyperparameters = dict(hyperparameters or {})
        self.methods = _team_methods(critic, agent_id, independent, net, previous if self.resume else None)
        self.methods.check(self.algo, bc=bc_expert is not None, workers=workers)
        if progress_bar:
            _require("tqdm", "the progress bar")
            _require("rich", "the progress bar")
        if self.tensorboard_log is not None:
            _require("tensorboard", "TensorBoard logging")
        self.bc = previous.get("bc") if isinstance(previous.get("bc"), dict) else None
        self.bc_pending = bc_expert is not None
        if bc_expert is not None:  # an empty name is refused by make_expert below
            if self.resume:
                raise ValueError("behaviour cloning (--bc-expert) pre-trains a new model; it cannot be combined with --resume")
            if self.algo not in ("ppo", "a2c", "maskable_ppo", *sorted(RECURRENT_ALGORITHMS)):
                raise ValueError(
                    "behaviour cloning (--bc-expert) needs an actor-critic policy (ppo, a2c, maskable_ppo, "
                    f"recurrent_ppo or maskable_recurrent_ppo), not {self.algo}"
                )
            if bc_steps < 1 or bc_epochs < 1:
                raise ValueError(f"bc_steps and bc_epochs must be >= 1, got {bc_steps} and {bc_epochs}")
            if bc_dagger < 0 or any(n is not None and n < 1 for n in (bc_dagger_steps, bc_dagger_epochs, bc_batch_size)):
                raise ValueError(
                    f"bc_dagger must be >= 0 and its steps and epochs and bc_batch_size >= 1, "
                    f"got {bc_dagger}, {bc_dagger_steps}, {bc_dagger_epochs}, {bc_batch_size}"
                )
            self.bc = {"expert": bc_expert, "steps": int(bc_steps), "epochs": int(bc_epochs)}
            if bc_dagger:
                self.bc.update(dagger_rounds=int(bc_dagger), dagger_steps=bc_dagger_steps, dagger_epochs=bc_dagger_epochs)
            if bc_batch_size is not None:
                self.bc["batch_size"] = int(bc_batch_size)
            if bc_noise is not None:
                if not 0 <= bc_noise <= 1:
                    raise ValueError(f"bc_noise must be in [0, 1], got {bc_noise}")
                self.bc["noise"] = float(bc_noise)
            if bc_expert_kwargs:
                if not isinstance(bc_expert_kwargs, Mapping) or not all(isinstance(k, str) for k in bc_expert_kwargs):
                    raise ValueError(f"bc expert_kwargs must map argument names to values, got {bc_expert_kwargs!r}")
                self.bc["expert_kwargs"] = dict(bc_expert_kwargs)
            self.bc.update(_clone_options(bc_learning_rate, bc_std_fraction, bc_label_smoothing, bc_fit_value))
        settings = MessageSettings(message_levels, message_tokens, message_vocab).check()
        if threads is not None:
            import torch

            torch.set_num_threads(threads)
        probe = teamgym.make(env_id, **self.config)  # validate id and config (and the expert) before building the VecEnv
        try:
            action_space = probe.action_space(probe.possible_agents[0])
            self.codec: MessageCodec | None = None
            if is_message_space(action_space):  # comm_dim / protocol_messages: one flat action of motion ⊕ message
                self.codec = MessageCodec(action_space, settings)
                action_space = self.codec.space
            elif settings.given():
                raise ValueError(
                    f"--message-levels/--message-tokens/--message-vocab flatten a motion ⊕ message action (comm_dim > 0, "
                    f"or Rendezvous' protocol_messages=True); {env_id}'s action space is {action_space}"
                )
            check_action_space(self.algo, action_space)
            check_masks(self.algo, probe)
            self.methods.check_env(probe)
            self.policy_spec = self.methods.policy(self.algo, probe)
            slots = self.n_envs * len(probe.possible_agents)  # TeamVecEnv's num_envs
            base = resumed_hp if self.resume else default_hyperparameters(self.algo, slots)
            check_rollout(self.algo, {**base, **hyperparameters}, action_space, slots)
            if bc_expert is not None:
                from baselines.rl.imitation import make_expert

                make_expert(bc_expert, probe, **self.bc.get("expert_kwargs", {}))
        finally:
            probe.close()
        if not 1 <= workers <= self.n_envs:
            raise ValueError(f"workers must be in [1, n_envs={self.n_envs}], got {workers}")
        self.workers, self.preset = int(workers), preset

        def make_copy() -> Any:
            env = teamgym.make(env_id, **self.config)
            return FlatMessageActions(env, settings) if self.codec is not None else env

        self.make_copy = make_copy  # the training env of one copy (behaviour cloning plays in it too)

        if self.workers == 1:
            self.venv = self.methods.make_venv(make_copy, self.n_envs)
        else:
            from baselines.rl.subproc import SubprocTeamVecEnv

            self.venv = SubprocTeamVecEnv(make_copy, self.n_envs, n_workers=self.workers)
        if self.algo == MASKED_RECURRENT:  # the masks ride in the observations (baselines.rl.masked_recurrent)
            from baselines.rl.masked_recurrent import MasksInObservation

            self.venv = MasksInObservation(self.venv)
        self.eval_env = None
        self.padding_log = PaddingShareLog()
        try:
            self.agents_per_env = self.venv.agents_per_env
            if self.resume:
                try:
                    self.model = cls.load(str(self.resume), env=self.venv, device="cpu", **hyperparameters)
                except ValueError:  # SB3's own message, e.g. spaces that do not fit the env
                    raise
                except Exception as error:  # noqa: BLE001 - a damaged or foreign file: one clear message
                    raise ValueError(f"cannot load {str(self.resume)!r} as a {cls.__name__} model: {error}") from None
                self.resumed_at = int(self.model.num_timesteps)
                self.model.verbose = verbose
                self.model.tensorboard_log = self.tensorboard_log
                self.reset_seed = self.seed + self.resumed_at  # new episodes, not a replay of the first run's
                self.model.set_random_seed(self.reset_seed)
                saved = previous.get("hyperparameters")
                self.params = {**(saved if isinstance(saved, dict) else {}), **{k: repr(v) for k, v in hyperparameters.items()}}
            else:
                self.resumed_at, self.reset_seed = None, self.seed
                params = default_hyperparameters(self.algo, self.venv.num_envs)
                params.update(hyperparameters)
                if self.algo == MASKED_RECURRENT:
                    params["policy_kwargs"] = {**(params.get("policy_kwargs") or {}), "mask_width": self.venv.width}
                policy, policy_kwargs = self.policy_spec
                if policy_kwargs:  # the methods' (baselines.rl.team_methods) beside the user's
                    params_in = {**params, "policy_kwargs": {**params.get("policy_kwargs", {}), **policy_kwargs}}
                else:
                    params_in = params
                self.model = cls(
                    policy,
                    self.venv,
                    seed=self.seed,
                    verbose=verbose,
                    device="cpu",
                    tensorboard_log=self.tensorboard_log,
                    **params_in,
                )
                self.params = {k: repr(v) for k, v in params.items()}
                self.init_copied = load_weights(self.model, self.init, cls) if self.init is not None else None
            if self.eval_every:
                train_seeds = {self.reset_seed + e * self.agents_per_env for e in range(self.n_envs)}
                clash = sorted(s for s in train_seeds if self.eval_seed <= s < self.eval_seed + self.eval_episodes)
                if clash:
                    raise ValueError(
                        f"the evaluation seeds {self.eval_seed}..{self.eval_seed + self.eval_episodes - 1} include the "
                        f"training envs' reset seeds {clash}; choose held-out seeds outside them"
                    )
                self.eval_env = make_copy()
            # A resumed run continues the eval log and the best model up to its timestep; a new run starts them afresh.
            upto = self.resumed_at or 0
            csv_path = eval_csv_path(self.out)
            self.eval_log = EvalLog.continued(csv_path, upto) if self.resume and self.eval_every else EvalLog(csv_path)
            self.best: dict[str, Any] | None = None
            best = read_sidecar(best_path(self.out)) if self.resume and self.eval_every else None
            if best and isinstance(best.get("best_eval"), dict) and int(best["best_eval"].get("timesteps", upto + 1)) <= upto:
                self.best = dict(best["best_eval"])
        except BaseException:
            self.close()
            raise
        self.resolved = self.venv.get_attr("config", [0])[0].as_dict()
        self.started = time.time()

    # -- saving --------------------------------------------------------------------------
    def meta(self, kind: str = "final") -> dict[str, Any]:
        """The sidecar of a model saved now (``kind``: ``final``, ``checkpoint``, ``best`` or ``interrupted``)."""
        meta: dict[str, Any] = {
            "env": self.env_id,
            "config": self.resolved,
            "overrides": {k: str(v) for k, v in self.config.items()},
            "algo": self.algo,
            "timesteps": self.timesteps,
            "trained_timesteps": int(self.model.num_timesteps),
            "seed": self.seed,
            "n_envs": self.n_envs,
            "agents_per_env": self.agents_per_env,
            "hyperparameters": self.params,
            "wall_time_s": round(time.time() - self.started, 3),
            "kind": "final" if kind == "interrupted" else kind,
            "model": str(self.out),
            "resumed_from": str(self.resume) if self.resume else None,
            "init": {"model": str(self.init), "copied": self.init_copied} if self.init else None,
            "resumed_at": self.resumed_at,
            "reset_seed": self.reset_seed,
            "tensorboard": self.tensorboard_log,
            "tb_log_name": self.tb_log_name,
            "checkpoint_every": self.checkpoint_every,
            "bc": self.bc,
            "preset": self.preset,
            "workers": self.workers,
            "padding_share": self.padding_log.padding_share,
            "eval": (
                {
                    "every": self.eval_every,
                    "episodes": self.eval_episodes,
                    "seed": self.eval_seed,
                    "csv": str(self.eval_log.path),
                    "best": str(best_path(self.out)),
                }
                if self.eval_every
                else None
            ),
        }
        if self.codec is not None:
            meta["message_actions"] = self.codec.record()
        meta.update(self.methods.sidecar())
        if kind == "interrupted":
            meta["interrupted"] = True
        return meta

    def save(self, path: Path, kind: str = "final", **extra: Any) -> Path:
        """Save the model at ``path`` (``.zip``) with its sidecar ``.json``."""
        from baselines.learned import write_sidecar

        path.parent.mkdir(parents=True, exist_ok=True)
        self.model.save(str(path))
        write_sidecar(path.with_suffix(".json"), "sb3", {**self.meta(kind), **extra})
        return path

    def _checkpoint(self, timesteps: int) -> None:
        self.save(checkpoint_path(self.out, timesteps), "checkpoint")

    def _evaluate(self, timesteps: int) -> None:
        from baselines.rl.callbacks import evaluate_model, is_better

        assert self.eval_env is not None
        summary = evaluate_model(self.model, self.eval_env, self.eval_episodes, self.eval_seed, features=self.methods.features)
        row = self.eval_log.append(timesteps, summary)
        logger = self.model.logger
        for key, value in row.items():
            if key != "timesteps" and math.isfinite(value):
                logger.record(f"eval/{key}", value)
        logger.dump(timesteps)
        if is_better(row, self.best):
            self.best = {"timesteps": int(timesteps), "success_rate": row["success_rate"], "mean_return": row["mean_return"]}
            self.save(best_path(self.out), "best", best_eval=self.best)

    # -- running -------------------------------------------------------------------------
    def callbacks(self) -> list[Any]:
        """The SB3 callbacks of this run: checkpoints, periodic evaluation, then the caller's."""
        from baselines.rl.callbacks import EveryTimesteps

        callbacks: list[Any] = [self.padding_log]
        if self.checkpoint_every:
            callbacks.append(EveryTimesteps(self.checkpoint_every, self._checkpoint))
        if self.eval_every:
            callbacks.append(EveryTimesteps(self.eval_every, self._evaluate, at_start=self.resume is None, at_end=True))
        if self.callback is not None:
            callbacks += list(self.callback) if isinstance(self.callback, (list, tuple)) else [self.callback]
        return callbacks

    def learn(self) -> Path:
        """Train, save the model and its sidecar at :attr:`out` and return that path; the envs are closed after.

        On ``KeyboardInterrupt`` the model trained so far is saved (sidecar ``"interrupted": true``)
        and the interrupt re-raised.
        """
        from stable_baselines3.common.callbacks import CallbackList

        callbacks = self.callbacks()
        if self.resume and self.tensorboard_log is not None:
            self._continue_tensorboard_run()
        self.started = time.time()
        try:
            if self.bc_pending:
                self._pretrain()
            self.model.learn(
                total_timesteps=self.timesteps,
                callback=CallbackList(callbacks) if callbacks else None,
                reset_num_timesteps=self.resume is None,
                tb_log_name=self.tb_log_name,
                progress_bar=self.progress_bar,
            )
        except KeyboardInterrupt:
            self.save(self.out, "interrupted")
            raise
        finally:
            self.close()
        return self.save(self.out, "final")

    def _pretrain(self) -> None:
        """Behaviour-clone the expert into the new model (before its first rollout; wall time counts in the sidecar)."""
        from baselines.rl.imitation import pretrain

        assert self.bc is not None
        bc = self.bc
        record = pretrain(
            self.model,
            self.make_copy,
            bc["expert"],
            bc["steps"],
            bc["epochs"],
            self.seed,
            dagger_rounds=bc.get("dagger_rounds", 0),
            dagger_steps=bc.get("dagger_steps"),
            dagger_epochs=bc.get("dagger_epochs"),
            noise=bc.get("noise", DEFAULT_BC_NOISE),
            expert_kwargs=bc.get("expert_kwargs"),
            **{option: bc[option] for option in ("batch_size", *_CLONE_OPTIONS.values()) if option in bc},
        )
        self.bc.update(record)
        self.bc_pending = False
        if self.model.verbose >= 1:
            print(f"behaviour cloning from {self.bc['expert']!r}: {record}", flush=True)

    def _continue_tensorboard_run(self) -> None:
        """Log a resumed run into the latest ``<tb_log_name>_<k>`` directory, or ``_1`` if there is none yet.

        (SB3 alone would name a first directory ``_0`` when resuming into a new TensorBoard folder.)
        """
        from stable_baselines3.common.logger import configure
        from stable_baselines3.common.utils import get_latest_run_id

        assert self.tensorboard_log is not None
        if get_latest_run_id(self.tensorboard_log, self.tb_log_name) == 0:
            formats = ["stdout", "tensorboard"] if self.model.verbose >= 1 else ["tensorboard"]
            self.model.set_logger(configure(os.path.join(self.tensorboard_log, f"{self.tb_log_name}_1"), formats))

    def close(self) -> None:
        """Close the training and evaluation envs."""
        for env in (getattr(self, "venv", None), getattr(self, "eval_env", None)):
            if env is not None:
                env.close()


#: Behaviour-cloning settings of :func:`baselines.rl.imitation.behaviour_clone`: ``Training`` argument -> its keyword.
_CLONE_OPTIONS = {
    "bc_learning_rate": "learning_rate",
    "bc_std_fraction": "std_fraction",
    "bc_label_smoothing": "label_smoothing",
    "bc_fit_value": "fit_value",
}


def _clone_options(
    learning_rate: float | None, std_fraction: float | None, label_smoothing: float | None, fit_value: bool | None
) -> dict[str, Any]:
    """The cloning settings given (``None``: the default), checked; one-line ``ValueError`` naming a bad one."""
    given = {"learning_rate": learning_rate, "std_fraction": std_fraction, "label_smoothing": label_smoothing}
    for name, value in given.items():
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"bc_{name} must be a finite number, got {value!r}")
    if learning_rate is not None and learning_rate <= 0:
        raise ValueError(f"bc_learning_rate must be > 0, got {learning_rate}")
    if std_fraction is not None and std_fraction <= 0:
        raise ValueError(f"bc_std_fraction must be > 0, got {std_fraction}")
    if label_smoothing is not None and not 0 <= label_smoothing < 1:
        raise ValueError(f"bc_label_smoothing must be in [0, 1), got {label_smoothing}")
    if fit_value is not None and not isinstance(fit_value, bool):
        raise ValueError(f"bc_fit_value must be True or False, got {fit_value!r}")
    out: dict[str, Any] = {k: float(v) for k, v in given.items() if v is not None}
    if fit_value is not None:
        out["fit_value"] = fit_value
    return out


def train(
    env_id: str = DEFAULT_ENV,
    algo: str = DEFAULT_ALGO,
    timesteps: int = 100_000,
    seed: int = 0,
    out: str | Path = "model.zip",
    config: Mapping[str, Any] | None = None,
    n_envs: int = DEFAULT_N_ENVS,
    hyperparameters: Mapping[str, Any] | None = None,
    verbose: int = 0,
    threads: int | None = 1,
    **options: Any,
) -> Path:
    """Train ``algo`` with parameter sharing on ``n_envs`` copies of ``env_id`` and save it to ``out``.

    Returns the path of the saved ``.zip``; a sidecar ``.json`` with the run's settings is
    written next to it. ``threads`` sets ``torch.set_num_threads`` (small MLPs train
    fastest single-threaded on CPU; ``None`` leaves torch's setting alone). Keyword
    ``options`` of :class:`Training`: ``tensorboard_log``, ``tb_log_name``,
    ``progress_bar``, ``checkpoint_every``, ``eval_every``, ``eval_episodes``,
    ``eval_seed``, ``resume`` (a saved model to continue: ``timesteps`` more, its counter
    kept; ``env_id``, ``algo`` and ``config`` must fit it), ``callback`` (extra SB3
    callbacks) and ``bc_expert``, ``bc_steps``, ``bc_epochs``, ``bc_dagger``,
    ``bc_dagger_steps``, ``bc_dagger_epochs``, ``bc_batch_size``, ``bc_noise``, ``bc_expert_kwargs`` (behaviour cloning and
    DAgger rounds before training); see the module docstring.
    """
    run = Training(env_id, algo, timesteps, seed, out, config, n_envs, hyperparameters, verbose, threads, **options)
    return run.learn()


def _train_in_process(kwargs: dict[str, Any], log: str) -> str:
    """Worker of :func:`train_seeds` with ``jobs > 1``: one run, its output to ``log``."""
    from contextlib import redirect_stderr, redirect_stdout

    with open(log, "w") as handle, redirect_stdout(handle), redirect_stderr(handle):
        return str(train(**kwargs))


def seed_run_path(out_dir: str | Path, seed: int, env_id: str, algo: str) -> Path:
    """``<out_dir>/seed<seed>/<env>_<algo>.zip``: the model of one seed of :func:`train_seeds`."""
    from baselines.rl.sb3_policy import algorithm_name

    return Path(out_dir) / f"seed{seed}" / f"{env_id}_{algorithm_name(algo)}.zip"


def train_seeds(
    seeds: Sequence[int],
    out_dir: str | Path,
    jobs: int = 1,
    *,
    on_done: Callable[[int, Path], None] | None = None,
    **kwargs: Any,
) -> list[Path]:
    """Train one model per seed into ``<out_dir>/seed<k>/`` (see :func:`seed_run_path`); returns the model paths.

    ``kwargs`` are those of :func:`train` except ``seed``, ``out`` and ``resume``; each
    seed's TensorBoard run is named ``seed<k>``. Runs go one after the other, or with
    ``jobs > 1`` in that many worker processes (each writes its output to
    ``<out_dir>/seed<k>/train.log``). ``<out_dir>/runs.json`` lists the seeds and models.
    ``on_done(seed, path)`` is called as each run finishes.
    """
    if not seeds:
        raise ValueError("seeds must not be empty")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct, got {list(seeds)}")
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    for key in ("seed", "out", "resume"):
        if key in kwargs:
            raise ValueError(f"train_seeds() sets {key!r} itself")
    env_id, algo = kwargs.get("env_id", DEFAULT_ENV), kwargs.get("algo", DEFAULT_ALGO)
    out_dir = Path(out_dir)
    paths = {s: seed_run_path(out_dir, s, env_id, algo) for s in seeds}
    settings = {k: (str(v) if isinstance(v, Path) else v) for k, v in kwargs.items() if k != "callback"}
    _write_json(
        out_dir / "runs.json",
        {"seeds": list(seeds), "models": {str(s): str(p) for s, p in paths.items()}, "settings": settings},
    )
    per_seed = {s: {**kwargs, "seed": s, "out": paths[s], "tb_log_name": f"seed{s}"} for s in seeds}
    if jobs == 1 or len(seeds) == 1:
        for s in seeds:
            train(**per_seed[s])
            if on_done:
                on_done(s, paths[s])
        return [paths[s] for s in seeds]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    if "callback" in kwargs:
        raise ValueError("callbacks cannot be sent to worker processes; use jobs=1")
    for path in paths.values():
        path.parent.mkdir(parents=True, exist_ok=True)
    context = multiprocessing.get_context("spawn")  # forking after torch's threads start can hang
    with ProcessPoolExecutor(max_workers=min(jobs, len(seeds)), mp_context=context) as pool:
        futures = {pool.submit(_train_in_process, per_seed[s], str(paths[s].parent / "train.log")): s for s in seeds}
        for future in as_completed(futures):
            future.result()
            if on_done:
                on_done(futures[future], paths[futures[future]])
    return [paths[s] for s in seeds]


# -- command line -----------------------------------------------------------------------


def _seed_list(text: str) -> list[int]:
    """An argparse ``type``: comma-separated distinct seeds ``>= 0``."""
    try:
        seeds = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers such as 0,1,2, got {text!r}") from None
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"expected distinct seeds >= 0 such as 0,1,2, got {text!r}")
    return seeds


def _algorithm_arg(text: str) -> str:
    """``--algo``: an algorithm name in any common spelling, as its registered name."""
    from baselines.rl.sb3_policy import algorithm_name

    try:
        return algorithm_name(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.train`` argument parser (a bad command line exits 2 with a one-line error)."""
    from baselines.cli import Parser, at_least, nonblank
    from baselines.rl.sb3_policy import ALGORITHMS

    parser = Parser(prog="python -m baselines.train", description="Train a parameter-shared SB3 policy on a teamgym env.")
    count, natural = at_least(1), at_least(0)
    resumed = "; with --resume: the saved run's"
    parser.add_argument("--env", type=nonblank("an env id"), default=None, help=f"env id (default: {DEFAULT_ENV}{resumed})")
    parser.add_argument(
        "--algo",
        default=None,
        type=_algorithm_arg,
        metavar="ALGO",
        help=f"SB3 algorithm: {', '.join(sorted(ALGORITHMS))}; hyphens work too, e.g. maskable-ppo "
        f"(default: {DEFAULT_ALGO}{resumed})",
    )
    parser.add_argument(
        "--timesteps",
        type=count,
        default=None,
        help="agent transitions to train for (with --resume: on top of the model's; default: the preset's, else 100000)",
    )
    parser.add_argument("--seed", type=natural, default=None, help=f"random seed (default: 0{resumed})")
    parser.add_argument(
        "--seeds", type=_seed_list, default=None, metavar="S1,S2,...", help="train one model per seed into <out>/seed<k>/"
    )
    parser.add_argument("--jobs", type=count, default=1, help="with --seeds: parallel training processes (default: 1)")
    parser.add_argument(
        "--out",
        type=nonblank("a path"),
        default=None,
        help="model path (.zip; default: results/models/<env>_<algo>.zip); with --seeds a directory "
        "(default: results/models/<env>_<algo>/)",
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config override (repeatable)")
    parser.add_argument("--max-cycles", type=count, default=None, help="shorthand for --set max_cycles=M")
    parser.add_argument(
        "--n-envs", type=count, default=None, help=f"env copies (each gives one SB3 env per robot; default: 4{resumed})"
    )
    parser.add_argument(
        "--hp", action="append", default=[], metavar="KEY=VALUE", help="algorithm keyword argument, e.g. learning_rate=1e-4"
    )
    parser.add_argument("--threads", type=count, default=1, help="torch CPU threads (default: 1)")
    parser.add_argument("--verbose", type=int, choices=(0, 1, 2), default=1, help="SB3 verbosity (default: 1)")
    parser.add_argument(
        "--tensorboard",
        type=nonblank("a directory"),
        default=None,
        metavar="DIR",
        help=f"write TensorBoard logs under DIR{resumed}",
    )
    parser.add_argument("--progress-bar", action="store_true", help="show SB3's progress bar (needs tqdm and rich)")
    parser.add_argument(
        "--checkpoint-every",
        type=natural,
        default=None,
        metavar="N",
        help=f"save <out-stem>_<steps>_steps.zip every N timesteps (0: off; default: off{resumed})",
    )
    parser.add_argument(
        "--resume", type=nonblank("a model path"), default=None, metavar="PATH", help="continue training the model saved at PATH"
    )
    parser.add_argument(
        "--init",
        type=nonblank("a model path"),
        default=None,
        metavar="PATH",
        help="start a new run from the policy weights of the model saved at PATH (or a shipped agent name)",
    )
    parser.add_argument(
        "--eval-every",
        type=natural,
        default=None,
        metavar="N",
        help=f"evaluate on held-out seeds every N timesteps (0: off; default: off{resumed})",
    )
    parser.add_argument(
        "--eval-episodes", type=count, default=None, metavar="K", help=f"episodes per evaluation (default: 10{resumed})"
    )
    parser.add_argument(
        "--eval-seed",
        type=natural,
        default=None,
        metavar="S",
        help=f"first held-out seed; evaluation i uses S..S+K-1 (default: {DEFAULT_EVAL_SEED}{resumed})",
    )
    parser.add_argument(
        "--preset",
        type=nonblank("a preset name"),
        default=None,
        metavar="NAME",
        help="train with a shipped RL preset (env, config, algo, hyper-parameters, budget; see docs/training.md); "
        "other options override its values",
    )
    parser.add_argument(
        "--workers", type=count, default=None, help="step the env copies in this many worker processes (default: 1)"
    )
    parser.add_argument(
        "--bc-expert",
        type=nonblank("a scripted policy name"),
        default=None,
        metavar="NAME",
        help="behaviour-clone this scripted policy before training (ppo, a2c)",
    )
    parser.add_argument(
        "--bc-steps", type=count, default=None, metavar="N", help=f"expert transitions to clone (default: {DEFAULT_BC_STEPS})"
    )
    parser.add_argument(
        "--bc-epochs", type=count, default=None, metavar="K", help=f"passes over them (default: {DEFAULT_BC_EPOCHS})"
    )
    parser.add_argument(
        "--bc-dagger",
        type=int,
        default=None,
        metavar="R",
        help="then R rounds of DAgger: the clone drives, the expert labels, the clone is refitted on all data (default: 0)",
    )
    _add_knobs(parser)
    _add_method_arguments(parser)
    return parser


def _real(low: float, high: float | None = None, *, open_low: bool = False, open_high: bool = False) -> Callable[[str], float]:
    """An argparse ``type``: a finite number in the given range."""
    shown = f"{'(' if open_low else '['}{low:g}, {'inf)' if high is None else f'{high:g}' + (')' if open_high else ']')}"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number in {shown}, got {text!r}") from None
        above = value > low if open_low else value >= low
        below = high is None or (value < high if open_high else value <= high)
        if not (math.isfinite(value) and above and below):
            raise argparse.ArgumentTypeError(f"expected a number in {shown}, got {text!r}")
        return value

    return parse


#: The imitation and message options (``--bc-...`` beyond expert, steps, epochs and DAgger rounds; ``--message-...``).
_BC_KNOBS = (
    "bc_noise",
    "bc_batch_size",
    "bc_lr",
    "bc_std_fraction",
    "bc_label_smoothing",
    "bc_no_value",
    "bc_expert_kwargs",
)
_BC_DAGGER_KNOBS = ("bc_dagger_steps", "bc_dagger_epochs")


def _add_knobs(parser: argparse.ArgumentParser) -> None:
    """``--bc-noise`` and the other cloning settings, and ``--message-levels/tokens/vocab`` (learned messages)."""
    from baselines.cli import at_least, json_object
    from baselines.rl.imitation import DEFAULT_STD_FRACTION
    from baselines.rl.message_actions import DEFAULT_LEVELS, DEFAULT_TOKENS, DEFAULT_VOCAB

    count = at_least(1)
    parser.add_argument(
        "--bc-expert-kwargs",
        type=json_object,
        default=None,
        metavar="JSON",
        help='the expert\'s keyword arguments, a JSON object, e.g. \'{"params": {"max_hold": 0}}\' for dmaps '
        "(default: a preset's bc.expert_kwargs when its expert is used, else none)",
    )
    parser.add_argument(
        "--bc-noise",
        type=_real(0, 1),
        default=None,
        metavar="X",
        help=f"DART noise of the executed expert actions while collecting, 0 = none (default: {DEFAULT_BC_NOISE})",
    )
    parser.add_argument("--bc-batch-size", type=count, default=None, metavar="B", help="cloning mini-batch (default: 64)")
    parser.add_argument(
        "--bc-lr", type=_real(0, open_low=True), default=None, metavar="LR", help="cloning Adam step size (default: 1e-3)"
    )
    parser.add_argument(
        "--bc-std-fraction",
        type=_real(0, open_low=True),
        default=None,
        metavar="F",
        help=f"Box action std after cloning, as a fraction of the half range (default: {DEFAULT_STD_FRACTION})",
    )
    parser.add_argument(
        "--bc-label-smoothing",
        type=_real(0, 1, open_high=True),
        default=None,
        metavar="E",
        help="label smoothing of the discrete cloning loss (default: 0.1)",
    )
    parser.add_argument(
        "--bc-no-value", action="store_true", default=None, help="do not fit the value head to the expert's returns"
    )
    parser.add_argument(
        "--bc-dagger-steps", type=count, default=None, metavar="N", help="transitions per DAgger round (default: --bc-steps)"
    )
    parser.add_argument(
        "--bc-dagger-epochs", type=count, default=None, metavar="K", help="passes per DAgger refit (default: --bc-epochs)"
    )
    parser.add_argument(
        "--message-levels",
        type=at_least(2),
        default=None,
        metavar="L",
        help=f"comm_dim with discrete motion: values per message entry (default: {DEFAULT_LEVELS})",
    )
    parser.add_argument(
        "--message-tokens",
        type=count,
        default=None,
        metavar="K",
        help=f"protocol_messages: message values the policy writes (default: {DEFAULT_TOKENS})",
    )
    parser.add_argument(
        "--message-vocab",
        type=at_least(2),
        default=None,
        metavar="V",
        help=f"protocol_messages: values per token, -1 .. V-2 (default: {DEFAULT_VOCAB})",
    )


def _add_method_arguments(parser: argparse.ArgumentParser) -> None:
    """``--critic``, ``--agent-id``, ``--independent``, ``--net`` (:mod:`baselines.rl.team_methods`)."""
    from baselines.rl.cell_policy import NETS
    from baselines.rl.team_methods import CRITICS

    parser.add_argument(
        "--critic",
        choices=CRITICS,
        default=None,
        help="local: the critic reads the robot's observation (default); central: also the team state() (MAPPO-style; "
        "ppo, a2c, maskable_ppo)",
    )
    parser.add_argument(
        "--agent-id", action="store_true", default=None, help="append a one-hot of the robot's index to its observation"
    )
    parser.add_argument(
        "--independent",
        action="store_true",
        default=None,
        help="one policy per robot, no shared parameters (fixed teams; ppo, a2c, maskable_ppo; one zip holds them all)",
    )
    parser.add_argument(
        "--net",
        choices=NETS,
        default=None,
        help="mlp: SB3's MLP over the flat observation (default); cells: a go-to-cell action scored cell by cell over "
        "the observation's grid layers (Foraging-v0 goto_cell with observe_world_model/observe_novelty; ppo, a2c, "
        "maskable_ppo)",
    )


def _preset_settings(name: str, env_id: str | None) -> dict[str, Any]:
    """A preset in the shape of a saved sidecar (``env``, ``algo``, ``overrides``, ...) for :func:`_plan`."""
    from baselines.rl.hyperparameters import check_hyperparameters
    from baselines.rl.presets import load_preset

    preset = load_preset(name)
    if env_id is not None and env_id != preset.env:
        raise ValueError(f"preset {name!r} is for {preset.env}, not {env_id}")
    try:
        check_hyperparameters(preset.algo, preset.hyperparameters)
    except ValueError as error:
        raise ValueError(f"preset {name!r}: {error}") from None
    return {
        "env": preset.env,
        "algo": preset.algo,
        "overrides": {k: repr(v) if not isinstance(v, str) else v for k, v in preset.config.items()},
        "n_envs": preset.n_envs,
        "timesteps": preset.timesteps,
        "hyperparameters": dict(preset.hyperparameters),
        "bc": preset.bc,
        "eval": preset.eval,
        "init": preset.init,
        "critic": preset.critic,
        "agent_id": preset.agent_id,
        "net": preset.net,
        "message_actions": preset.message_actions,
    }


def _pick(given: Any, saved: Any, default: Any) -> Any:
    """The command line's value, else the resumed run's, else the default."""
    if given is not None:
        return given
    return saved if saved is not None else default


def _plan(args: argparse.Namespace) -> tuple[dict[str, Any], list[int] | None]:
    """Keyword arguments of :class:`Training` (without ``seed``/``out`` for ``--seeds``) and the seeds, from the command line."""
    from baselines.cli import check_out, parse_pairs
    from baselines.rl.sb3_policy import detect_algorithm, read_sidecar, resolve_model
    from teamgym.envs.config import parse_value

    if args.seeds is not None and args.seed is not None:
        raise ValueError("give --seed or --seeds, not both")
    if args.seeds is not None and args.resume:
        raise ValueError("--resume continues one model; it cannot be combined with --seeds")
    if args.jobs > 1 and args.seeds is None:
        raise ValueError("--jobs needs --seeds")
    if args.jobs > 1 and args.progress_bar:
        raise ValueError("--progress-bar shows one run; it cannot be combined with --jobs > 1")
    if args.bc_expert is None and (args.bc_steps is not None or args.bc_epochs is not None):
        raise ValueError("--bc-steps and --bc-epochs need --bc-expert")
    if args.bc_dagger is not None and args.bc_dagger < 0:
        raise ValueError(f"--bc-dagger must be >= 0, got {args.bc_dagger}")
    if args.bc_expert is not None and args.resume:
        raise ValueError("--bc-expert pre-trains a new model; it cannot be combined with --resume")
    sets: dict[str, Any] = parse_pairs(args.set, "--set")
    if args.max_cycles is not None:
        sets["max_cycles"] = str(args.max_cycles)
    hyperparameters = {k: parse_value(v) for k, v in parse_pairs(args.hp, "--hp").items()}
    saved: dict[str, Any] = {}
    if args.preset is not None:
        if args.resume:
            raise ValueError("--preset starts a new run; --resume takes its settings from the model's sidecar")
        saved = _preset_settings(args.preset, args.env)
        sets = {**saved["overrides"], **sets}
        hyperparameters = {**saved["hyperparameters"], **hyperparameters}
    if args.resume:
        path = resolve_model(args.resume)
        saved = read_sidecar(path) or {}
        saved_algo = saved.get("algo") or detect_algorithm(path)
        if args.algo and saved_algo and args.algo != saved_algo:
            raise ValueError(f"--algo {args.algo}: the model {str(path)!r} was trained with {saved_algo}")
        saved["algo"] = saved_algo
    env_id = _pick(args.env, saved.get("env"), DEFAULT_ENV)
    overrides = saved.get("overrides") if env_id == saved.get("env") and isinstance(saved.get("overrides"), dict) else {}
    if args.preset is not None:
        overrides = {}  # already merged into sets
    config = {**overrides, **sets}
    algo = _pick(args.algo, saved.get("algo"), DEFAULT_ALGO)
    evaluation = saved.get("eval") if isinstance(saved.get("eval"), dict) else {}
    eval_every = _pick(args.eval_every, evaluation.get("every"), 0)
    if not eval_every and (args.eval_episodes is not None or args.eval_seed is not None):
        raise ValueError("--eval-episodes and --eval-seed need --eval-every")
    kwargs: dict[str, Any] = {
        "env_id": env_id,
        "algo": algo,
        "timesteps": _pick(args.timesteps, saved.get("timesteps") if args.preset else None, 100_000),
        "config": config,
        "n_envs": _pick(args.n_envs, saved.get("n_envs"), DEFAULT_N_ENVS),
        "hyperparameters": hyperparameters,
        "verbose": args.verbose,
        "threads": args.threads,
        "tensorboard_log": _pick(args.tensorboard, saved.get("tensorboard"), None),
        "progress_bar": args.progress_bar,
        "checkpoint_every": _pick(args.checkpoint_every, saved.get("checkpoint_every"), 0) or None,
        "eval_every": eval_every or None,
        "eval_episodes": _pick(args.eval_episodes, evaluation.get("episodes"), DEFAULT_EVAL_EPISODES),
        "eval_seed": _pick(args.eval_seed, evaluation.get("seed"), DEFAULT_EVAL_SEED),
    }
    if args.preset is not None:
        kwargs["preset"] = args.preset
    init = args.init if args.init is not None else saved.get("init") if args.preset else None
    if init is not None:
        if args.resume:
            raise ValueError("--init starts a new model from saved weights; it cannot be combined with --resume")
        kwargs["init"] = init
    if args.workers is not None:
        kwargs["workers"] = args.workers
    for name in ("critic", "agent_id", "independent", "net"):
        if getattr(args, name, None) is not None:
            kwargs[name] = getattr(args, name)
        elif args.preset is not None and saved.get(name) is not None:
            kwargs[name] = saved[name]
    bc = saved.get("bc") if args.preset and isinstance(saved.get("bc"), dict) else {}
    expert = args.bc_expert if args.bc_expert is not None else bc.get("expert")
    if expert is not None:  # a --bc-expert other than the preset's keeps the preset's amounts unless given
        kwargs["bc_expert"] = expert
        kwargs["bc_steps"] = _pick(args.bc_steps, bc.get("steps"), DEFAULT_BC_STEPS)
        kwargs["bc_epochs"] = _pick(args.bc_epochs, bc.get("epochs"), DEFAULT_BC_EPOCHS)
        kwargs["bc_dagger"] = _pick(args.bc_dagger, bc.get("dagger_rounds"), 0)
        kwargs["bc_dagger_steps"] = _pick(args.bc_dagger_steps, bc.get("dagger_steps"), None)
        kwargs["bc_dagger_epochs"] = _pick(args.bc_dagger_epochs, bc.get("dagger_epochs"), None)
        kwargs["bc_batch_size"] = _pick(args.bc_batch_size, bc.get("batch_size"), None)
        kwargs["bc_noise"] = _pick(args.bc_noise, bc.get("noise"), None)
        kwargs["bc_learning_rate"] = _pick(args.bc_lr, bc.get("learning_rate"), None)
        kwargs["bc_std_fraction"] = _pick(args.bc_std_fraction, bc.get("std_fraction"), None)
        kwargs["bc_label_smoothing"] = _pick(args.bc_label_smoothing, bc.get("label_smoothing"), None)
        kwargs["bc_fit_value"] = False if args.bc_no_value else bc.get("fit_value")
        if args.bc_expert_kwargs is not None:
            kwargs["bc_expert_kwargs"] = args.bc_expert_kwargs
        elif expert == bc.get("expert"):  # the preset's expert arguments fit only its expert
            kwargs["bc_expert_kwargs"] = bc.get("expert_kwargs")
    elif args.bc_dagger:
        raise ValueError("--bc-dagger needs --bc-expert (or a preset with behaviour cloning)")
    else:
        given = [f"--{k.replace('_', '-')}" for k in (*_BC_KNOBS, *_BC_DAGGER_KNOBS) if getattr(args, k) is not None]
        if given:
            raise ValueError(f"{', '.join(given)} need --bc-expert (or a preset with behaviour cloning)")
    from_saved = args.resume or args.preset is not None
    message = saved.get("message_actions") if from_saved and isinstance(saved.get("message_actions"), dict) else {}
    for key in ("levels", "tokens", "vocab"):
        value = _pick(getattr(args, f"message_{key}"), message.get(key), None)
        if value is not None:
            kwargs[f"message_{key}"] = value
    if args.seeds is not None:
        out_dir = Path(args.out) if args.out is not None else Path("results") / "models" / f"{env_id}_{algo}"
        if out_dir.suffix == ".zip" or out_dir.is_file():
            raise ValueError(f"with --seeds, --out names a directory, not {str(out_dir)!r}")
        check_out(out_dir)
        kwargs["out"] = out_dir
        return kwargs, args.seeds
    if args.resume:
        kwargs["resume"] = args.resume
        kwargs["tb_log_name"] = saved.get("tb_log_name")
        out = Path(args.out) if args.out is not None else continued_path(resolve_model(args.resume))
    else:
        out = Path(args.out) if args.out is not None else Path("results") / "models" / f"{env_id}_{algo}.zip"
    check_out(_zip_path(out), file=True)
    kwargs["out"] = out
    kwargs["seed"] = _pick(args.seed, saved.get("seed"), 0)
    return kwargs, None


#: Errors of a bad command line or configuration found while setting a run up (exit code 2); SB3 checks
#: some of its settings with ``assert``.
_BAD_INPUT = (ValueError, TypeError, KeyError, FileNotFoundError, ImportError, AssertionError)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the training CLI; returns the exit code.

    2 with one ``error: ...`` line for usage or configuration errors (found before any env is
    trained); 1 with one line for any other failure (``TEAMGYM_TRACEBACK=1`` re-raises it); 130
    on Ctrl-C (the model trained so far is saved).
    """
    from baselines.cli import guarded, message, parse_args

    args = parse_args(build_parser(), argv)
    if isinstance(args, int):  # --help, or a usage error already reported in one line
        return args

    def body() -> int:
        run: Training | None = None
        try:
            kwargs, seeds = _plan(args)
            if seeds is None:
                run = Training(**kwargs)
            else:  # validate the settings with the first seed's run before training any
                out_dir = kwargs.pop("out")
                Training(**kwargs, seed=seeds[0], out=seed_run_path(out_dir, seeds[0], kwargs["env_id"], kwargs["algo"])).close()
        except _BAD_INPUT as error:
            print(f"error: {message(error)}", file=sys.stderr)
            return 2
        try:
            if run is not None:
                path = run.learn()
                print(f"saved {path} (settings in {path.with_suffix('.json')})")
                if run.eval_every:
                    print(f"evaluations in {run.eval_log.path}; best model {best_path(path)} ({run.best})")
            else:
                assert seeds is not None

                def report(seed: int, path: Path) -> None:
                    print(f"seed {seed}: saved {path}", flush=True)

                train_seeds(seeds, out_dir, args.jobs, on_done=report, **kwargs)
                print(f"runs listed in {Path(out_dir) / 'runs.json'}")
        except KeyboardInterrupt:
            if run is None:
                raise  # guarded: "error: interrupted", 130
            where = f"the model so far is saved at {run.out} (continue with --resume {run.out})"
            print(f"error: interrupted; {where}", file=sys.stderr)
            return 130
        return 0

    return guarded(body)


if __name__ == "__main__":
    sys.exit(main())
