"""Scripted vs learned on one env: the paper's baseline, the simple ones, a trained agent and random, on held-out seeds.

Command line::

    python -m baselines.rl.compare --env Navigation-v0 --agent navigation-ppo
        [--episodes 100] [--seed 20000] [--workers 2] [--set key=value ...] [--out DIR]

Every policy plays the same seeds ``S .. S+K-1`` (never used to reset a training env: those
start at the training seed, and held-out evaluation during training starts at 10 000) through
:func:`baselines.evaluate.evaluate`. Scripted policies run on the env's default config plus
``--set`` and what they require (``nash`` its heading actions); the agent (``--agent``: a shipped
agent's name, an SB3 model path or ``sb3:PATH``, or ``rllib:CHECKPOINT``) runs on the config
overrides of its sidecar (:mod:`baselines.learned`) plus ``--set``. The agent's config changes how
actions and observations are encoded and the reward weights, and may choose a setting such as
the team size (see :mod:`baselines.rl.presets`); every row is judged on the same task, so an
agent whose training settings give it another team than the scripted rows get (trained with
``n_robots=8`` or in BoxPushing's ``situation=S3``, compared without that ``--set``) is a one-line
error naming those settings, before any episode.

The table (printed, and written to ``DIR/comparison.md`` and ``DIR/comparison.json``) gives per
policy: success with its Wilson 95 % interval; *clean* success (success and no contact of any
robot, for envs that count collisions); the time to success (s: the latest simulated time the
env reports, ``time_to_goal``, ``explore_time``, ``meeting_time`` or Foraging's ``TG``, else ``length × dt`` of
successful episodes); path length per
robot (m) and collisions per robot, as means with 95 % intervals; and the env's own metrics
(``OWN_METRICS``: Foraging's TL, TT1-TT3, TG, DG; Rendezvous' meeting time, re-plans, plan
optimality and bytes sent; ...), per episode the mean over its robots of the values known. With ``--curve``, the agent's
learning curve (its ``<agent>_eval.csv``; ``--curve-metric``: success rate, collisions or path length) is
drawn with the scripted rows' values as lines.

``--agent DIR`` may name the output directory of ``baselines.train --seeds`` (its ``runs.json``):
every seed's model then plays the held-out seeds (:func:`baselines.rl.seeds.evaluate_seeds`), the
agent's row is the median seed's, and the row's ``across_seeds`` (printed under the table) holds
each metric's IQM and mean across the seeds with 95 % stratified-bootstrap intervals; ``--curve``
draws the seeds' learning curves as one, their mean with its band.

A bad command line (``--episodes`` above ``baselines.evaluate.MAX_EPISODES``, an empty ``--env``,
``--agent`` or ``--out``), env id, task config, agent, ``--out`` that cannot be written or missing
learning curve exits 2 with one ``error: ...`` line before any policy plays.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from baselines.episode import EpisodeResult
from baselines.stats import mean_ci, wilson

__all__ = ["SCRIPTED", "agent_policy", "compare", "episode_values", "main", "row_of", "single_thread_torch"]

#: Per env: the paper's baseline first, then the simple ones and random (label, policy name).
SCRIPTED: dict[str, list[tuple[str, str]]] = {
    "Navigation-v0": [("nash (paper 001)", "nash"), ("goto", "goto"), ("random", "random")],
    "Exploration-v0": [("nash-explore (paper 000)", "nash-explore"), ("greedy", "greedy"), ("random", "random-admissible")],
    "BoxPushing-v0": [("sbs (paper 004)", "sbs"), ("cooperative-push", "cooperative-push"), ("random", "random")],
    "BoxPushing-v1": [("sbs (paper 004)", "sbs"), ("cooperative-push", "cooperative-push"), ("random", "random")],
    "Rendezvous-v0": [
        ("bidir-astar (paper 003)", "bidir-astar"),
        ("bidir-astar-opt", "bidir-astar-opt"),
        ("centralized", "centralized"),
        ("place-beacon (learned channel)", "place-beacon"),
        ("random", "random"),
    ],
    "Foraging-v0": [
        ("dmaps (paper 002)", "dmaps"),
        ("dmaps-nocomm", "dmaps-nocomm"),
        ("random-walk", "random-walk"),
        ("random", "random"),
    ],
}

#: Per env: its own metrics (``infos`` keys), shown beside the common columns as means over episodes
#: (each episode's value is the mean over its robots; times only where known).
OWN_METRICS: dict[str, tuple[str, ...]] = {
    "Navigation-v0": ("time_to_goal", "min_clearance", "smoothness"),
    "Exploration-v0": ("explore_time", "explored_fraction", "tasks_failed"),
    "BoxPushing-v0": ("boxes_delivered", "box_progress", "stalled_steps"),
    "BoxPushing-v1": ("boxes_delivered", "box_progress", "stalled_steps"),
    "Rendezvous-v0": ("meeting_time", "replans", "optimality", "bytes_sent"),
    "Foraging-v0": ("TL", "TT1", "TT2", "TT3", "TG", "DG", "bytes_sent"),
}


def _metric(result: EpisodeResult, name: str) -> list[float]:
    return [float(m[name]) for m in result.metrics.values() if name in m and m[name] is not None]


#: Metrics in which envs report the simulated time (s) at which their goal was reached.
TIME_METRICS = ("time_to_goal", "explore_time", "meeting_time", "TG")


def _time_to_success(result: EpisodeResult, dt: float | None) -> float | None:
    """Simulated seconds to success: the latest of the env's reported times, else ``length × dt``.

    Envs with macro actions (Exploration's operators) count ``length`` in decisions, not
    control steps, so their reported time is the only right one.
    """
    if not result.success:
        return None
    for name in TIME_METRICS:
        times = _metric(result, name)
        if times:
            return max(times)
    return result.length * dt if dt else None


def row_of(
    label: str, policy: str, results: Sequence[EpisodeResult], dt: float | None, own: Sequence[str] = ()
) -> dict[str, Any]:
    """One table row: rates with Wilson intervals, means with 95 % half-widths (``own``: the env's metrics, under ``metrics``)."""
    n = len(results)
    successes = sum(r.success for r in results)
    has_collisions = any(_metric(r, "collisions") for r in results)
    clean = sum(r.success and sum(_metric(r, "collisions")) == 0 for r in results) if has_collisions else None
    times = [t for t in (_time_to_success(r, dt) for r in results) if t is not None]
    paths = [float(np.mean(_metric(r, "path_length"))) for r in results if _metric(r, "path_length")]
    collisions = [float(np.mean(_metric(r, "collisions"))) for r in results if _metric(r, "collisions")]
    return {
        "label": label,
        "policy": policy,
        "episodes": n,
        "success": successes / n,
        "success_ci": list(wilson(successes, n)),
        "clean_success": None if clean is None else clean / n,
        "clean_success_ci": None if clean is None else list(wilson(clean, n)),
        "time_to_success": mean_ci(times),
        "path_length": mean_ci(paths),
        "collisions": mean_ci(collisions),
        "metrics": {name: mean_ci([float(np.mean(_metric(r, name))) for r in results if _metric(r, name)]) for name in own},
    }


def episode_values(results: Sequence[EpisodeResult], dt: float | None, own: Sequence[str] = ()) -> dict[str, list[float]]:
    """Per column of :func:`row_of`, its per-episode values (what the row's rates and means are taken over).

    ``success`` and ``clean_success`` as 0/1 (``clean_success`` only for envs that count collisions),
    ``time_to_success`` of successful episodes only, and per episode the mean over its robots of
    ``path_length``, ``collisions`` and each of ``own`` that any robot reports (episodes without it left out).
    """
    values: dict[str, list[float]] = {"success": [float(r.success) for r in results]}
    if any(_metric(r, "collisions") for r in results):
        values["clean_success"] = [float(r.success and sum(_metric(r, "collisions")) == 0) for r in results]
    values["time_to_success"] = [t for t in (_time_to_success(r, dt) for r in results) if t is not None]
    for name in ("path_length", "collisions", *own):
        values[name] = [float(np.mean(_metric(r, name))) for r in results if _metric(r, name)]
    return values


def _rate(value: float | None, ci: Sequence[float] | None) -> str:
    if value is None or ci is None:
        return "–"
    low, high = (max(0.0, 100 * ci[0]), min(100.0, 100 * ci[1]))
    return f"{100 * value:.0f} % [{low:.0f}, {high:.0f}]"


def _mean(stats: Mapping[str, float], digits: int) -> str:
    if not stats["n"]:
        return "–"
    half = "" if math.isnan(stats["ci95"]) else f" ± {stats['ci95']:.{digits}f}"
    return f"{stats['mean']:.{digits}f}{half}"


def markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """The comparison as a markdown table (the env's own metrics that any row reports as extra columns)."""
    own = [name for name in rows[0].get("metrics", {}) if any(row["metrics"][name]["n"] for row in rows)] if rows else []
    lines = [
        "| policy | success | clean success (no contact) | time to success (s) | path length / robot (m) | collisions / robot |"
        + "".join(f" {name} |" for name in own),
        "|---|---|---|---|---|---|" + "---|" * len(own),
    ]
    for row in rows:
        lines.append(
            f"| {row['label']} | {_rate(row['success'], row['success_ci'])} | "
            f"{_rate(row['clean_success'], row['clean_success_ci'])} | {_mean(row['time_to_success'], 1)} | "
            f"{_mean(row['path_length'], 2)} | {_mean(row['collisions'], 2)} |"
            + "".join(f" {_mean(row['metrics'][name], 2)} |" for name in own)
        )
    return "\n".join(lines)


def compare(
    env_id: str,
    agent: str | None,
    episodes: int = 100,
    seed: int = 20_000,
    workers: int = 1,
    task: Mapping[str, Any] | None = None,
    policies: Sequence[tuple[str, str]] | None = None,
    results: dict[str, list[EpisodeResult]] | None = None,
) -> list[dict[str, Any]]:
    """Rows for the scripted policies of ``env_id`` (or ``policies``) and the agent (:func:`agent_policy`), seeds ``seed ..``.

    ``results``, if given, receives each row's episode results under its label. An ``agent`` that is a
    ``--seeds`` run directory gives the median seed's row with ``across_seeds`` (see the module docstring;
    its episodes are not put in ``results``).
    """
    import teamgym
    from baselines.evaluate import evaluate
    from baselines.learned import is_learned
    from baselines.registry import required_config

    task = dict(task or {})
    if policies is None and env_id not in SCRIPTED:
        print(f"note: no scripted baselines are listed for {env_id}; comparing with random only", file=sys.stderr)
    entries = list(policies if policies is not None else SCRIPTED.get(env_id, [("random", "random")]))
    agent_config: dict[str, Any] = {}
    seeds_record, label_of_agent = None, f"trained: {agent}"
    if agent is not None and run_directory(agent) is not None:
        from baselines.rl.seeds import evaluate_seeds

        seeds_record = evaluate_seeds(agent, episodes, seed, workers, task)
        median = seeds_record["median_seed"]
        label_of_agent = f"trained: {agent} (seed {median}, the median of {len(seeds_record['seeds'])})"
        agent = seeds_record["median_model"]
    if agent is not None:
        policy = agent_policy(agent)
        agent_config = agent_settings(env_id, agent, policy)
        if entries:
            check_same_team(env_id, agent, agent_config, task)
        entries.insert(-1 if entries and entries[-1][0] == "random" else len(entries), (label_of_agent, policy))
    dt = float(teamgym.make(env_id, **task).config.dt)
    rows = []
    for label, policy in entries:
        if seeds_record is not None and label == label_of_agent:
            row = seeds_record["per_seed"][str(seeds_record["median_seed"])]
            rows.append({**row, "label": label, "policy": policy, "across_seeds": seeds_record["across_seeds"]})
            continue
        config = {**agent_config, **task} if is_learned(policy) else {**required_config(policy), **task}
        played = evaluate(env_id, policy, episodes=episodes, seed=seed, config=config, workers=workers)
        rows.append(row_of(label, policy, played, dt, OWN_METRICS.get(env_id, ())))
        if results is not None:
            results[label] = played
    return rows


def agent_settings(env_id: str, agent: str, policy: str) -> dict[str, Any]:
    """The config overrides the agent was trained with (its sidecar's ``overrides``), as ``baselines.evaluate`` applies them.

    The resolved ``config`` would also pin keys a task option derives (BoxPushing's situation sets
    the robot and box counts) and contradict a ``--set situation=...``. ``ValueError`` if the
    sidecar names another env."""
    from baselines.learned import policy_sidecar

    found = policy_sidecar(policy)
    sidecar = found[0] if found else {}
    if sidecar.get("env") not in (None, env_id):
        raise ValueError(f"agent {agent!r} was trained on {sidecar['env']}, not {env_id}")
    return dict(sidecar["overrides"] if "overrides" in sidecar else sidecar.get("config") or {})


def check_same_team(env_id: str, agent: str, agent_config: Mapping[str, Any], task: Mapping[str, Any]) -> None:
    """A ``ValueError`` when the agent's training settings give it another team size than the scripted rows get.

    The agent plays with its sidecar's settings (``agent_config``) plus ``--set`` (``task``), the scripted
    rows with ``--set`` alone, so an agent trained at ``n_robots=8`` (or in BoxPushing's ``situation=S3``)
    compared without that ``--set`` would be scored on another task than the rows beside it."""
    import teamgym

    agent_config = {**agent_config, **task}
    mine, theirs = (len(teamgym.make(env_id, **config).possible_agents) for config in (agent_config, task))
    if mine != theirs:
        settings = ", ".join(f"{k}={v}" for k, v in agent_config.items() if k not in task) or "none"
        raise ValueError(
            f"agent {agent!r} plays {mine} robots with its training settings ({settings}) and the scripted rows {theirs}: "
            "give the task's settings with --set so that every row plays the same task"
        )


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.rl.compare`` argument parser (a bad command line exits 2 with a one-line error)."""
    from baselines.cli import Parser, at_least, nonblank
    from baselines.evaluate import MAX_EPISODES

    parser = Parser(prog="python -m baselines.rl.compare", description=__doc__.splitlines()[0])
    parser.add_argument("--env", type=nonblank("an env id"), default="Navigation-v0", help="env id (default: Navigation-v0)")
    parser.add_argument(
        "--agent",
        type=nonblank("a shipped agent name, a model path or rllib:CHECKPOINT"),
        default=None,
        help="a shipped agent name, an SB3 model path (or sb3:PATH) or rllib:CHECKPOINT; none: scripted only",
    )
    parser.add_argument(
        "--episodes",
        type=at_least(1, MAX_EPISODES),
        default=100,
        help=f"held-out episodes per policy, 1 to {MAX_EPISODES} (default: 100)",
    )
    parser.add_argument("--seed", type=at_least(0), default=20_000, help="first held-out seed, >= 0 (default: 20000)")
    parser.add_argument("--workers", type=at_least(1), default=1, help="worker processes, >= 1 (default: 1)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="task config for every policy")
    parser.add_argument(
        "--out", type=nonblank("a directory"), default=None, help="directory for comparison.md/.json (and curve.png)"
    )
    parser.add_argument("--curve", action="store_true", help="draw the agent's learning curve (needs its _eval.csv)")
    parser.add_argument(
        "--curve-metric",
        choices=sorted(CURVE_METRICS),
        default="success_rate",
        help="what the curve shows (default: success_rate); the scripted rows' values are drawn as lines",
    )
    return parser


#: Learning-curve metrics (columns of an ``_eval.csv``) and the comparison-row value drawn beside them.
CURVE_METRICS: dict[str, Callable[[Mapping[str, Any]], float]] = {
    "success_rate": lambda row: row["success"],
    "mean_collisions": lambda row: row["collisions"]["mean"],
    "mean_path_length": lambda row: row["path_length"]["mean"],
}


def agent_policy(agent: str) -> str:
    """The policy name of ``--agent``: ``rllib:CHECKPOINT`` as given, else ``sb3:`` and the SB3 model it names.

    ``FileNotFoundError`` if there is no such checkpoint or model (a shipped agent's name is one).
    """
    from baselines.learned import split_scheme
    from baselines.rl.sb3_policy import resolve_model

    split = split_scheme(agent)
    if split is not None and split[0] == "rllib":
        from baselines.rl.rllib import module_path

        module_path(split[1])
        return agent
    return f"sb3:{resolve_model(split[1] if split else agent)}"


def run_directory(agent: str) -> Path | None:
    """``agent`` as a ``baselines.train --seeds`` output directory (one holding ``runs.json``), else ``None``."""
    path = Path(agent)
    return path if (path / "runs.json").is_file() else None


def across_seeds_text(row: Mapping[str, Any]) -> str:
    """Under the table: the row's IQM of each metric across seeds with its 95 % bootstrap interval ('' without)."""
    across = row.get("across_seeds")
    if not across:
        return ""
    parts = []
    for name, stats in across.items():
        scale, unit, digits = (100, " %", 0) if name in ("success", "clean_success") else (1, "", 2)
        low, high = (math.nan if v is None else v for v in stats["iqm_ci"])
        interval = f" [{scale * low:.{digits}f}, {scale * high:.{digits}f}]" if math.isfinite(low) and math.isfinite(high) else ""
        parts.append(f"{name} {scale * stats['iqm']:.{digits}f}{unit}{interval}")
    return f"{row['label']}, across {stats['runs']} seeds (IQM [95 % bootstrap CI]): " + "; ".join(parts)


def _curve_csvs(agent: str) -> list[Path]:
    """The learning curves of a run directory's seeds (every one needed), else :func:`_curve_csv` of the agent."""
    run_dir = run_directory(agent)
    if run_dir is None:
        return [_curve_csv(agent)]
    from baselines.rl.seeds import read_runs

    return [_curve_csv(str(path)) for path in read_runs(run_dir).values()]


def _curve_csv(agent: str) -> Path:
    """The agent's learning curve (``<model-stem>_eval.csv``); ``FileNotFoundError`` if there is none."""
    policy = agent_policy(agent)
    if not policy.startswith("sb3:"):
        raise FileNotFoundError(f"--curve reads an SB3 model's _eval.csv; {agent!r} is an RLlib checkpoint")
    path = Path(policy[4:])
    csv = path.with_name(f"{path.stem}_eval.csv")
    if not csv.is_file():
        raise FileNotFoundError(f"no learning curve beside the agent: {str(csv)!r}")
    return csv


def _curve(agent: str, rows: Sequence[Mapping[str, Any]], out: Path, metric: str = "success_rate") -> Path:
    from baselines.learned import is_learned
    from baselines.rl.plot_curves import load_curves, plot_curves

    curves = load_curves({f"trained: {agent}": _curve_csvs(agent)}, metric)
    value = CURVE_METRICS[metric]
    lines = [(row["label"], value(row), "") for row in rows if not is_learned(row["policy"])]
    return plot_curves(curves, out / "curve.png", metric, lines, title=f"{agent}: {metric} on held-out seeds while training")


def single_thread_torch() -> None:
    """Run torch on one thread, as ``baselines.evaluate``'s CLI does, for the CLIs that play episodes in-process.

    An SB3 policy predicts one robot's tiny batch per call; with torch's default thread count on a
    machine whose other cores are busy, each small matrix product waits for a second thread (measured
    with ``python -m baselines.rl.seeds`` on Navigation, 128x128 MLPs, 2 shared cores: 7.1 CPU-s per
    episode with 2 threads, at most 0.7 with 1). Worker processes already run single-threaded.
    """
    try:
        import torch
    except ImportError:  # scripted policies only
        return
    torch.set_num_threads(1)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the comparison CLI: exit 2 with one line for bad arguments (``--out`` included) before any
    episode, 1 for a failure while playing."""
    import teamgym
    from baselines.cli import check_out, guarded, message, parse_args, parse_pairs

    args = parse_args(build_parser(), argv)
    if isinstance(args, int):  # --help, or a usage error already reported in one line
        return args
    try:
        if args.curve and (args.agent is None or args.out is None):
            raise ValueError("--curve needs --agent and --out")
        if args.out is not None:
            check_out(Path(args.out))
        task = parse_pairs(args.set, "--set")
        teamgym.make(args.env, **task).close()  # a bad env id or task config fails here, before any episode
        if args.agent is not None and run_directory(args.agent) is not None:
            from baselines.rl.seeds import read_runs

            read_runs(args.agent)  # every seed's model must be there
        elif args.agent is not None:
            policy = agent_policy(args.agent)
            check_same_team(args.env, args.agent, agent_settings(args.env, args.agent, policy), task)
        if args.curve:
            _curve_csvs(args.agent)
    except (ValueError, KeyError, FileNotFoundError) as error:
        print(f"error: {message(error)}", file=sys.stderr)
        return 2
    single_thread_torch()
    return guarded(lambda: _report(args, compare(args.env, args.agent, args.episodes, args.seed, args.workers, task)))


def _report(args: argparse.Namespace, rows: Sequence[Mapping[str, Any]]) -> int:
    table = markdown(rows)
    notes = [text for text in map(across_seeds_text, rows) if text]
    table = "\n\n".join([table, *notes])
    print(f"{args.env}, {args.episodes} held-out seeds from {args.seed}" + (f", task {args.set}" if args.set else ""))
    print(table)
    if args.out is not None:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "comparison.md").write_text(table + "\n")
        record = {"env": args.env, "seed": args.seed, "episodes": args.episodes, "task": args.set, "rows": rows}
        (out / "comparison.json").write_text(json.dumps(record, indent=2))
        if args.curve:
            print(f"wrote {_curve(args.agent, rows, out, args.curve_metric)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
