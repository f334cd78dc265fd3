"""Evaluate a policy on a teamgym env over seeded episodes; write a summary, a CSV and plots.

Command line::

    python -m baselines.evaluate [--env Navigation-v0] [--policy goto] [--episodes 10] [--seed 0]
        [--set key=value ...] [--max-cycles M] [--out DIR] [--gif] [--workers W|ray] [--ray-address ADDR]
        [--quiet] [--stochastic]

Episode ``i`` resets the env with seed ``S + i`` and the policy with ``policy.reset(S + i)``,
so results do not depend on ``--workers``. ``--workers ray`` runs the episodes on a Ray
cluster (one actor per CPU; ``--ray-address HOST:PORT`` or ``RAY_ADDRESS`` names an existing
cluster, else a local one starts; needs ``pip install ray``) with the same results.
``--policy sb3:PATH`` evaluates a saved Stable-Baselines3 model (see
:mod:`baselines.rl.sb3_policy`) and ``--policy rllib:PATH`` an RLlib checkpoint of
``python -m baselines.rl.rllib`` (:class:`baselines.rl.rllib.RLlibPolicy`; needs ``ray[rllib]``),
deterministically unless ``--stochastic``.

A policy trained by ``python -m baselines.train`` or ``python -m baselines.rl.rllib`` has a sidecar
(:mod:`baselines.learned`: ``<model>.json`` beside an SB3 model, ``teamgym.json`` in an RLlib
checkpoint) with the env id and config overrides it was trained with. When it exists they are the
defaults: the env is the sidecar's unless ``--env`` is given, and the config is the sidecar's overrides
updated with the ``--set``/``--max-cycles`` given (an explicit setting wins, key by key).
An ``--env`` other than the sidecar's drops the sidecar's overrides and is accepted only if
the policy's spaces fit that env (a note goes to stderr); otherwise it is a one-line error
naming both envs. Files written to ``DIR`` (default ``results/<env>_<policy>/``):

* ``summary.json``: env, policy, resolved config, episodes, seed, ``success_rate``,
  ``mean_episode_length``, ``mean_return`` and ``mean_<metric>`` for every numeric
  metric, plus ``metrics`` (mean/std/min/max/count of each), ``deterministic`` (false
  with ``--stochastic``), ``overrides`` (the ``--set`` and sidecar settings, as strings), for
  a learned policy with a sidecar ``sidecar`` (its path) and, with ``--workers ray``, ``ray_nodes``
  (the episodes each Ray node ran, by node id);
* ``episodes.csv``: one row per episode (seed, length, success, mean return over robots
  and the per-episode mean of every metric over the robots that report it);
* ``trajectories.png``: the robots' (and moving obstacles' or boxes') paths in the first episode;
* ``episode.gif`` (with ``--gif``): an animation of the first episode.

Success is the episode contract's: ``infos[agent]["success"]`` of an episode's last step
(one episode: :func:`baselines.episode.run_episode`, re-exported here); it is the
``success`` column, never a metric column.

Errors: a bad command line (an empty ``--env``, ``--policy`` or ``--out`` included, ``--episodes``
above :data:`MAX_EPISODES` = 10**6), env id, config, ``--out`` (an existing file, under one, or
not writable) or a policy that does not fit the env (``Policy.check_env``) exits with code 2
and one ``error: ...`` line before any episode runs; a failure while running exits with code 1
and one line (``TEAMGYM_TRACEBACK=1`` shows the traceback instead). Seeds are made episode by
episode, never listed up front.

Metric means pool all (robot, episode) values: a metric a robot does not report (such as
``time_to_goal`` before arrival) is left out rather than counted as zero; booleans count
as 0/1 (so ``mean_arrived`` is the arrival rate). Non-finite means are written as ``null``.

The pieces live in their own modules: the command-line toolkit in :mod:`baselines.cli`, the
summary, tables and writers in :mod:`baselines.summary`, the serial, process-pool and Ray runners in
:mod:`baselines.runners` (names imported from here before they moved still import from here).

From Python::

    from baselines.evaluate import evaluate, summarise
    results = evaluate("Navigation-v0", "goto", episodes=20, seed=0, config={"n_robots": 5}, workers=2)
    summary = summarise(results)
"""

from __future__ import annotations

import os

if __name__ == "__main__":  # the CLI: one numeric thread per process, set before numpy loads
    for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, "1")

import argparse
import importlib
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from baselines.cli import (
    Parser,
    UsageError,
    at_least,
    check_out,
    cluster_address,
    guarded,
    json_object,
    message,
    nonblank,
    one_line,
    parse_args,
    parse_pairs,
    workers_or_ray,
)
from baselines.episode import EpisodeResult, metric_names, run_episode
from baselines.learned import is_learned, policy_sidecar, split_scheme
from baselines.runners import EpisodeRunner, Episodes, check_ray_address, require_ray, run_episodes
from baselines.summary import markdown_table, summarise, summary_table, write_episodes_csv, write_summary_json

__all__ = [
    "MAX_EPISODES",
    "EpisodeResult",
    "build_parser",
    "check_ray_address",
    "evaluate",
    "main",
    "markdown_table",
    "metric_names",
    "require_ray",
    "run_episode",
    "summarise",
    "summary_table",
    "write_episodes_csv",
    "write_summary_json",
]

#: Names that lived here before :mod:`baselines.cli`, :mod:`baselines.summary` and :mod:`baselines.runners`
#: took them: old name -> (module, name there). Importing one from here still works.
_MOVED: dict[str, tuple[str, str]] = {
    "_at_least": ("baselines.cli", "at_least"),
    "_check_out": ("baselines.cli", "check_out"),
    "_message": ("baselines.cli", "message"),
    "_nonblank": ("baselines.cli", "nonblank"),
    "_one_line": ("baselines.cli", "one_line"),
    "_parse_sets": ("baselines.cli", "parse_pairs"),
    "_Parser": ("baselines.cli", "Parser"),
    "_ray_address": ("baselines.cli", "cluster_address"),
    "_UsageError": ("baselines.cli", "UsageError"),
    "_workers": ("baselines.cli", "workers_or_ray"),
    "_json_safe": ("baselines.summary", "json_safe"),
    "_stats": ("baselines.summary", "stats"),
    "_chunks": ("baselines.runners", "chunks"),
    "_Episodes": ("baselines.runners", "Episodes"),
    "_pool_context": ("baselines.runners", "pool_context"),
    "_Runner": ("baselines.runners", "EpisodeRunner"),
}


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        module, new = _MOVED[name]
        return getattr(importlib.import_module(module), new)
    raise AttributeError(f"module 'baselines.evaluate' has no attribute {name!r}")


#: The env evaluated when neither ``--env`` nor a learned policy's sidecar names one.
DEFAULT_ENV = "Navigation-v0"
#: The most episodes one evaluation runs: their results are kept for the summary and the CSV
#: (about 2 kB each for ``goto`` on Navigation-v0, 0.1 CPU-s to play), so more would not fit in memory.
MAX_EPISODES = 10**6


def evaluate(
    env_id: str = "Navigation-v0",
    policy_name: str = "goto",
    episodes: int = 10,
    seed: int = 0,
    config: Mapping[str, Any] | None = None,
    workers: int | str = 1,
    *,
    progress: bool = False,
    keep_trajectories: bool = False,
    policy_kwargs: Mapping[str, Any] | None = None,
    ray_address: str | None = None,
    ray_nodes: dict[str, int] | None = None,
) -> list[EpisodeResult]:
    """Run ``episodes`` episodes (seeds ``seed .. seed+episodes-1``) and return their results in seed order.

    ``episodes`` is at most :data:`MAX_EPISODES`; the seeds are made one by one, never listed.

    ``config`` is passed to ``teamgym.make`` (strings are parsed as on the command line).
    With ``workers > 1`` episodes run in that many worker processes (forked where possible),
    each with its own env and policy, handed out in chunks of consecutive seeds; results are
    identical to a sequential run. ``workers="ray"`` runs the chunks on Ray actors, one per CPU of
    the running Ray session or of ``ray.init(address=ray_address)`` (by default ``RAY_ADDRESS``,
    else a new local cluster; shut down after); results are again identical, and ``ray_nodes``
    (a dict, if given) gets the number of episodes each Ray node ran (:func:`baselines.runners.run_episodes`).
    Trajectories are kept for the first episode only unless ``keep_trajectories``. ``policy_kwargs``
    go to :func:`baselines.registry.make_policy` (e.g. ``{"deterministic": False}`` for an
    ``sb3:PATH`` or ``rllib:PATH`` policy). Config, env-id and policy errors
    (including a policy that does not fit the env) raise (``ConfigError``/``ValueError``/
    ``KeyError``/``FileNotFoundError``) before any episode runs.
    """
    if not 1 <= episodes <= MAX_EPISODES:
        raise ValueError(f"episodes must be in [1, {MAX_EPISODES}], got {episodes}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    if workers == "ray":
        ray = require_ray()
        if ray_address is not None:
            check_ray_address(ray_address)
            if ray.is_initialized():
                raise ValueError("ray_address was given, but this process already runs a Ray session (it would be used)")
    elif isinstance(workers, str) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1 or 'ray', got {workers!r}")
    elif ray_address is not None:
        raise ValueError(f"ray_address applies to workers='ray' only, not workers={workers!r}")
    from tqdm import tqdm

    config = dict(config or {})
    runner = EpisodeRunner(env_id, policy_name, config, policy_kwargs=policy_kwargs)  # validates env id, config and policy
    items = Episodes(seed, keep_trajectories, range(episodes))  # episode i: seed + i, trajectories of the first
    bar = tqdm(total=episodes, desc=f"{env_id} {policy_name}", unit="ep", disable=not progress, leave=False)
    try:
        serial = workers == 1 or (episodes == 1 and workers != "ray")
        if not serial:
            runner.close()  # the workers build their own
        return run_episodes(
            env_id,
            policy_name,
            config,
            items,
            workers,
            policy_kwargs=policy_kwargs,
            runner=runner if serial else None,
            on_done=bar.update,
            ray_address=ray_address,
            ray_nodes=ray_nodes,
        )
    finally:
        bar.close()
        runner.close()


def _model_defaults(
    policy: str, env_id: str | None, config: Mapping[str, str]
) -> tuple[str, dict[str, str], Path | None, str | None]:
    """Env id and config for ``policy``, completed from a learned policy's sidecar (:mod:`baselines.learned`).

    Returns ``(env_id, config, sidecar path or None, env the policy was trained on or None)``.
    The sidecar's overrides apply (explicit settings win) only when the env is the sidecar's.
    """
    config = dict(config)
    default = DEFAULT_ENV if env_id is None else env_id  # an empty --env is refused, never the default
    try:
        found = policy_sidecar(policy)
    except ValueError as error:
        raise UsageError(str(error)) from error
    if found is None or found[0].get("env") is None:
        return default, config, None, None
    sidecar, path = found
    trained_on = sidecar["env"]
    if env_id is not None and env_id != trained_on:
        return env_id, config, path, trained_on
    return trained_on, {**sidecar.get("overrides", {}), **config}, path, trained_on


def _slug(text: str) -> str:
    split = split_scheme(text)
    if split is not None:
        text = f"{split[0]}-{Path(split[1]).stem}"
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-") or "policy"


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.evaluate`` argument parser (a bad command line exits 2 with a one-line error)."""
    parser = Parser(
        prog="python -m baselines.evaluate",
        description="Evaluate a policy on a teamgym env over seeded episodes.",
    )
    seed = at_least(0)  # numpy rejects negative seeds
    parser.add_argument(
        "--env",
        type=nonblank("an env id"),
        default=None,
        help=f"env id (default: a learned policy's, from its sidecar; else {DEFAULT_ENV})",
    )
    parser.add_argument(
        "--policy",
        type=nonblank("a policy name, sb3:PATH or rllib:PATH"),
        default="goto",
        help="policy name, sb3:PATH (a Stable-Baselines3 model) or rllib:PATH (an RLlib checkpoint) (default: goto)",
    )
    parser.add_argument(
        "--episodes",
        type=at_least(1, MAX_EPISODES),
        default=10,
        help=f"number of episodes, 1 to {MAX_EPISODES} (default: 10)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="first seed, >= 0; episode i uses seed+i (default: 0)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config override (repeatable)")
    parser.add_argument("--max-cycles", type=int, default=None, help="shorthand for --set max_cycles=M")
    parser.add_argument(
        "--out", type=nonblank("a directory"), default=None, help="output directory (default: results/<env>_<policy>/)"
    )
    parser.add_argument("--gif", action="store_true", help="also write an animated GIF of the first episode")
    parser.add_argument("--no-plot", action="store_true", help="do not draw trajectories.png (matplotlib is then not loaded)")
    parser.add_argument(
        "--workers",
        type=workers_or_ray,
        default=1,
        help="parallel worker processes, >= 1, or 'ray': Ray actors, one per cluster CPU (RAY_ADDRESS; default: 1)",
    )
    parser.add_argument(
        "--ray-address",
        type=cluster_address,
        default=None,
        metavar="ADDR",
        help="with --workers ray: the Ray cluster to run on, HOST:PORT of its head (default: RAY_ADDRESS, else a new local one)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar or table")
    parser.add_argument(
        "--stochastic",
        action="store_true",
        help="sample a learned policy's actions (sb3:PATH, rllib:PATH) instead of taking the most likely",
    )
    parser.add_argument(
        "--policy-kwargs",
        type=json_object,
        default=None,
        metavar="JSON",
        help='keyword arguments of the policy, a JSON object, e.g. \'{"params": {"min_hold": 0}}\' for dmaps (default: none)',
    )
    parser.add_argument("--list", action="store_true", help="list env ids and policy names and exit")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the evaluation CLI; returns the exit code.

    Exit code 2, with one ``error: ...`` line on stderr and before any episode runs, for a
    bad command line, env id, config, policy, policy/env mismatch or ``--out``; 1, with
    one line, for a failure while running (``TEAMGYM_TRACEBACK=1`` re-raises it instead).
    """
    args = parse_args(build_parser(), argv)
    if isinstance(args, int):
        return args

    def body() -> int:
        try:
            return _run(args)
        except UsageError as error:
            print(f"error: {one_line(str(error))}", file=sys.stderr)
            return 2

    return guarded(body)


def _run(args: argparse.Namespace) -> int:
    """The CLI after parsing: validate everything, then run the episodes and write the outputs."""
    import teamgym
    from baselines.registry import policies

    if args.list:
        print("envs:     " + " ".join(teamgym.envs()))
        print("policies: " + " ".join(policies()) + " sb3:PATH rllib:PATH")
        return 0
    config = parse_pairs(args.set, "--set")
    if args.max_cycles is not None:
        config["max_cycles"] = str(args.max_cycles)
    if args.stochastic and not is_learned(args.policy):
        raise UsageError(f"--stochastic applies to learned policies (sb3:PATH, rllib:PATH) only, not {args.policy!r}")
    if args.ray_address is not None and args.workers != "ray":
        raise UsageError(f"--ray-address applies to --workers ray only, not --workers {args.workers}")
    if args.workers == "ray":
        try:
            require_ray()
        except ImportError as error:
            raise UsageError(str(error)) from error
    env_id, config, sidecar, trained_on = _model_defaults(args.policy, args.env, config)
    policy_kwargs = dict(args.policy_kwargs or {})
    if args.stochastic:
        if "deterministic" in policy_kwargs:
            raise UsageError("give --stochastic or a 'deterministic' key in --policy-kwargs, not both")
        policy_kwargs["deterministic"] = False
    name = _slug(args.policy) + ("-stochastic" if args.stochastic else "")
    out = Path(args.out) if args.out is not None else Path("results") / f"{_slug(env_id)}_{name}"
    check_out(out)
    try:
        probe = EpisodeRunner(env_id, args.policy, config, policy_kwargs=policy_kwargs)
    except (ValueError, TypeError, KeyError, FileNotFoundError, ImportError) as error:
        if trained_on is not None and trained_on != env_id:
            raise UsageError(
                f"the model was trained on {trained_on} (per {str(sidecar)!r}), not {env_id}: {message(error)}"
            ) from error
        raise UsageError(message(error)) from error
    if trained_on is not None and trained_on != env_id:
        print(
            f"note: the model was trained on {trained_on} (per {str(sidecar)!r}); its spaces fit {env_id}, "
            "so it is evaluated there without the sidecar's config",
            file=sys.stderr,
        )
    resolved = probe.env.config.as_dict() if hasattr(probe.env.config, "as_dict") else dict(config)
    if "torch" in sys.modules:  # an SB3 policy: tiny batches run fastest single-threaded
        sys.modules["torch"].set_num_threads(1)
    probe.close()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UsageError(f"cannot create --out {str(out)!r}: {error.strerror or error}") from error

    nodes: dict[str, int] = {}
    results = evaluate(
        env_id,
        args.policy,
        args.episodes,
        args.seed,
        config,
        args.workers,
        progress=not args.quiet,
        policy_kwargs=policy_kwargs,
        ray_address=args.ray_address,
        ray_nodes=nodes,
    )
    summary = {"env": env_id, "policy": args.policy, "config": resolved, "seed": args.seed, "workers": args.workers}
    summary.update(summarise(results))
    if args.workers == "ray":
        summary["ray_nodes"] = dict(sorted(nodes.items()))
    summary["deterministic"] = not args.stochastic
    if args.policy_kwargs:
        summary["policy_kwargs"] = args.policy_kwargs
    summary["overrides"] = {k: str(v) for k, v in config.items()}
    if sidecar is not None:
        summary["sidecar"] = str(sidecar)
    written = [write_summary_json(out / "summary.json", summary), write_episodes_csv(out / "episodes.csv", results)]

    first = results[0]
    if first.trajectories and not args.no_plot:
        from baselines.plots import plot_trajectories

        title = f"{env_id} · {args.policy} · seed {first.seed} · {'success' if first.success else 'no success'}"
        written.append(
            plot_trajectories(
                first.trajectories,
                out / "trajectories.png",
                arena=first.arena,
                goals=first.goals,
                title=title,
                walls=first.walls,
                furniture=first.furniture,
                objects=first.object_paths,
            )
        )
    if args.gif:
        from teamgym.sim.render import save_gif

        recorder = EpisodeRunner(env_id, args.policy, config, render_mode="rgb_array", policy_kwargs=policy_kwargs)
        try:
            replay = recorder.run(first.seed, record_frames=True)
            fps = float(recorder.env.metadata.get("render_fps") or 10)
        finally:
            recorder.close()
        if replay != first:
            print(f"warning: the rendered replay of seed {first.seed} differs from the evaluated episode", file=sys.stderr)
        written.append(save_gif(replay.frames or [], out / "episode.gif", fps=fps))

    if not args.quiet:
        seeds = f"seed {args.seed}" if args.episodes == 1 else f"seeds {args.seed}-{args.seed + args.episodes - 1}"
        mode = " (stochastic)" if args.stochastic else ""
        print(summary_table(summary, title=f"{env_id} | {args.policy}{mode} | {args.episodes} episodes ({seeds})"))
        for path in written:
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    # Re-enter through the importable module so spawned workers can unpickle its functions.
    from baselines.evaluate import main as _main

    sys.exit(_main())
