"""Train one parameter-shared Stable-Baselines3 model for every robot of a teamgym env.

Command line::

    python -m baselines.train [--env Navigation-v0] [--algo ppo] [--timesteps 100000] [--seed 0]
        [--out results/models/<env>_<algo>.zip] [--set key=value ...] [--max-cycles M]
        [--n-envs 4] [--hp key=value ...] [--verbose 0|1|2]

Timesteps count agent transitions (every robot's step is one SB3 step, see
:class:`baselines.rl.sb3_env.TeamVecEnv`). The model is saved to ``--out`` and a sidecar
``<out>.json`` records the env id, its config, the algorithm and the training settings.
Evaluate it with ``python -m baselines.evaluate --policy sb3:PATH --set ...`` (the same
config, so the observation size matches). DQN needs a discrete action space
(``--set action_type=heading``); SAC/TD3/DDPG need a continuous one.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["default_hyperparameters", "main", "train"]


def default_hyperparameters(algo: str, num_envs: int) -> dict[str, Any]:
    """Modest defaults: on-policy rollouts of ~2048 transitions in 8 equal mini-batches."""
    algo = algo.lower()
    if algo == "ppo":
        n_steps = max(8, math.ceil(2048 / num_envs / 8) * 8)
        return {"n_steps": n_steps, "batch_size": n_steps * num_envs // 8}
    if algo == "a2c":
        return {"n_steps": 8}
    return {}


def train(
    env_id: str = "Navigation-v0",
    algo: str = "ppo",
    timesteps: int = 100_000,
    seed: int = 0,
    out: str | Path = "model.zip",
    config: Mapping[str, Any] | None = None,
    n_envs: int = 4,
    hyperparameters: Mapping[str, Any] | None = None,
    verbose: int = 0,
    threads: int | None = 1,
) -> Path:
    """Train ``algo`` with parameter sharing on ``n_envs`` copies of ``env_id`` and save it to ``out``.

    Returns the path of the saved ``.zip``; a sidecar ``.json`` with the run's settings is
    written next to it. ``threads`` sets ``torch.set_num_threads`` (small MLPs train
    fastest single-threaded on CPU; ``None`` leaves torch's setting alone).
    """
    import teamgym
    from baselines.rl.sb3_env import TeamVecEnv
    from baselines.rl.sb3_policy import algorithm_class

    config = dict(config or {})
    cls = algorithm_class(algo)
    if threads is not None:
        import torch

        torch.set_num_threads(threads)
    teamgym.make(env_id, **config).close()  # validate id and config before building the VecEnv
    venv = TeamVecEnv(lambda: teamgym.make(env_id, **config), n_envs=n_envs)
    params = default_hyperparameters(algo, venv.num_envs)
    params.update(hyperparameters or {})
    model = cls("MlpPolicy", venv, seed=seed, verbose=verbose, device="cpu", **params)
    started = time.time()
    model.learn(total_timesteps=timesteps)
    out = Path(out)
    if out.suffix != ".zip":
        out = out.with_name(out.name + ".zip")
    out.parent.mkdir(parents=True, exist_ok=True)
    model.save(str(out))
    resolved = venv.envs[0].config.as_dict()
    venv.close()
    meta = {
        "env": env_id,
        "config": resolved,
        "overrides": {k: str(v) for k, v in config.items()},
        "algo": algo.lower(),
        "timesteps": int(timesteps),
        "trained_timesteps": int(model.num_timesteps),
        "seed": seed,
        "n_envs": n_envs,
        "agents_per_env": venv.agents_per_env,
        "hyperparameters": {k: repr(v) for k, v in params.items()},
        "wall_time_s": round(time.time() - started, 3),
    }
    out.with_suffix(".json").write_text(json.dumps(meta, indent=2) + "\n")
    return out


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.train`` argument parser."""
    from baselines.rl.sb3_policy import ALGORITHMS

    parser = argparse.ArgumentParser(
        prog="python -m baselines.train", description="Train a parameter-shared SB3 policy on a teamgym env."
    )
    parser.add_argument("--env", default="Navigation-v0", help="env id (default: Navigation-v0)")
    parser.add_argument("--algo", default="ppo", choices=sorted(ALGORITHMS), help="SB3 algorithm (default: ppo)")
    parser.add_argument("--timesteps", type=int, default=100_000, help="agent transitions to train for (default: 100000)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    parser.add_argument("--out", default=None, help="model path (.zip; default: results/models/<env>_<algo>.zip)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config override (repeatable)")
    parser.add_argument("--max-cycles", type=int, default=None, help="shorthand for --set max_cycles=M")
    parser.add_argument("--n-envs", type=int, default=4, help="env copies (each gives one SB3 env per robot; default: 4)")
    parser.add_argument(
        "--hp", action="append", default=[], metavar="KEY=VALUE", help="algorithm keyword argument, e.g. learning_rate=1e-4"
    )
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads (default: 1)")
    parser.add_argument("--verbose", type=int, default=1, help="SB3 verbosity (default: 1)")
    return parser


def _pairs(items: Sequence[str], flag: str) -> dict[str, str]:
    pairs = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"{flag} expects key=value, got {item!r}")
        pairs[key.strip()] = value.strip()
    return pairs


def main(argv: Sequence[str] | None = None) -> int:
    """Run the training CLI; returns the exit code (2 for usage or configuration errors)."""
    args = build_parser().parse_args(argv)
    import teamgym
    from teamgym.envs.config import parse_value

    try:
        if args.timesteps < 1:
            raise ValueError(f"--timesteps must be >= 1, got {args.timesteps}")
        if args.n_envs < 1:
            raise ValueError(f"--n-envs must be >= 1, got {args.n_envs}")
        config: dict[str, Any] = _pairs(args.set, "--set")
        if args.max_cycles is not None:
            config["max_cycles"] = str(args.max_cycles)
        hyperparameters = {k: parse_value(v) for k, v in _pairs(args.hp, "--hp").items()}
        teamgym.make(args.env, **config).close()
    except (ValueError, KeyError) as error:
        message = error.args[0] if isinstance(error, KeyError) and error.args else error
        print(f"error: {message}", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else Path("results") / "models" / f"{args.env}_{args.algo}.zip"
    path = train(
        args.env, args.algo, args.timesteps, args.seed, out, config, args.n_envs, hyperparameters, args.verbose, args.threads
    )
    print(f"saved {path} (settings in {path.with_suffix('.json')})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
