"""Results across training seeds of a ``--seeds`` run: per-seed Wilson intervals, IQM with bootstrap intervals, the median seed.

Command line::

    python -m baselines.rl.seeds DIR [--episodes 100] [--seed 31000] [--workers 1] [--set key=value ...]
        [--model final|best] [--metric success] [--resamples 2000] [--bootstrap-seed 0]
        [--curve [--curve-metric success_rate]] [--ship NAME [--agents-dir DIR] [--force]]

``DIR`` is the output directory of ``python -m baselines.train --seeds 0,1,2 --out DIR``
(:func:`baselines.rl.train.train_seeds`: ``DIR/runs.json`` and one model per seed in
``DIR/seed<k>/``). Every seed's model (``--model final``: ``<env>_<algo>.zip``; ``best``: the
``_best.zip`` of its periodic evaluations) plays the same held-out seeds ``S .. S+K-1``
(``--seed S``, ``--episodes K``) through :func:`baselines.rl.compare.compare`, i.e.
:func:`baselines.evaluate.evaluate` on the config of the model's sidecar plus ``--set``. The held-out
seeds must not overlap the seeds the runs were evaluated on while training (those chose the
``best`` model).

Written to ``DIR/seeds.json`` and ``DIR/seeds.md`` (and printed):

* per seed: the comparison row (:func:`baselines.rl.compare.row_of`: success and clean success
  with Wilson 95 % intervals over its episodes, time to success, path length, collisions and the
  env's own metrics as means with 95 % intervals);
* across seeds, per metric (:func:`baselines.seed_stats.across_runs`): each seed's score (its
  mean over the episodes), the interquartile mean of the scores and their mean, each with a 95 %
  stratified-bootstrap interval over seeds and episodes within seeds (``--resamples``, generator
  seed ``--bootstrap-seed``), the median; for success rates also the optimality gap to 100 %;
* the **median seed** by ``--metric`` (``success``, ``clean_success``, ``time_to_success``,
  ``path_length`` or ``collisions``): the seeds ordered from worst to best (ties broken by the time
  to success, then by success, then the lower seed first), the one at position ``(n-1)//2``; for an
  even count the worse of the middle two.

``--curve`` draws the learning curve across seeds to ``DIR/curve.png``: the IQM over the seeds'
``_eval.csv`` (``--curve-metric``, a column of theirs) with its 95 % bootstrap band over seeds and the
seeds as faint lines (:mod:`baselines.rl.plot_curves` with ``--center iqm --ci bootstrap``).

``--ship NAME`` then copies the median seed's model, sidecar and ``_eval.csv`` to
``baselines/rl/agents/NAME.zip``, ``NAME.json`` and ``NAME_eval.csv`` (``--agents-dir`` elsewhere),
the sidecar gaining a ``seeds`` field (:mod:`baselines.learned`) with these figures; an existing
``NAME`` is refused unless ``--force``.

A bad command line, run directory, env config or an existing ``--ship`` target exits 2 with one
``error: ...`` line before any episode; a failure while playing exits 1 with one line.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import shutil
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["METRICS", "build_parser", "evaluate_seeds", "main", "markdown", "median_seed", "read_runs", "ship"]

#: Metrics the median seed may be chosen by, and whether higher is better.
METRICS: dict[str, bool] = {
    "success": True,
    "clean_success": True,
    "time_to_success": False,
    "path_length": False,
    "collisions": False,
}
#: Metrics that are rates (targets of the optimality gap, shown in percent).
RATES = ("success", "clean_success")
DEFAULT_SEED, DEFAULT_EPISODES = 31_000, 100


def read_runs(run_dir: str | Path, model: str = "final") -> dict[int, Path]:
    """Training seed -> model path of the ``--seeds`` run in ``run_dir`` (``model``: ``final`` or ``best``).

    The models are looked up in ``run_dir/seed<k>/`` (so a moved run directory still reads).
    One-line ``ValueError``/``FileNotFoundError`` for a missing or malformed ``runs.json`` or model.
    """
    from baselines.rl.train import best_path

    if model not in ("final", "best"):
        raise ValueError(f"model must be 'final' or 'best', got {model!r}")
    run_dir = Path(run_dir)
    manifest_path = run_dir / "runs.json"
    if not manifest_path.is_file():
        raise FileNotFoundError(f"no runs.json in {str(run_dir)!r} (train with python -m baselines.train --seeds ... --out DIR)")
    try:
        manifest = json.loads(manifest_path.read_text())
        seeds = [int(s) for s in manifest["seeds"]]
        names = {int(s): Path(str(p)).name for s, p in manifest["models"].items()}
    except KeyError as error:
        raise ValueError(f"cannot read {str(manifest_path)!r}: it has no field {error}") from None
    except (OSError, ValueError, TypeError, AttributeError) as error:
        raise ValueError(f"cannot read {str(manifest_path)!r}: {' '.join(str(error).split())}") from None
    if not seeds or set(seeds) - set(names):
        raise ValueError(f"{str(manifest_path)!r} lists seeds {seeds} but models for {sorted(names)}")
    paths = {}
    for s in seeds:
        path = run_dir / f"seed{s}" / names[s]
        path = best_path(path) if model == "best" else path
        if not path.is_file():
            raise FileNotFoundError(
                f"seed {s} has no {model} model {str(path)!r}" + (" (train with --eval-every N)" if model == "best" else "")
            )
        paths[s] = path
    return paths


def _curve_of(model: Path) -> Path:
    """The ``_eval.csv`` of the run a model belongs to (a ``_best.zip``'s is its run's)."""
    from baselines.rl.train import eval_csv_path

    return eval_csv_path(model.with_name(model.name[: -len("_best.zip")] + ".zip") if model.name.endswith("_best.zip") else model)


def _sidecar(path: Path) -> dict[str, Any]:
    from baselines.learned import read_sidecar_file

    data = read_sidecar_file(path.with_suffix(".json"), "sb3")
    if data is None or not isinstance(data.get("env"), str):
        raise FileNotFoundError(f"the model {str(path)!r} has no sidecar naming its env ({path.with_suffix('.json').name})")
    return data


def _check_held_out(sidecars: Mapping[int, Mapping[str, Any]], seed: int, episodes: int) -> None:
    for s, sidecar in sidecars.items():
        evaluation = sidecar.get("eval")
        if isinstance(evaluation, dict) and "seed" in evaluation and "episodes" in evaluation:
            first, count = int(evaluation["seed"]), int(evaluation["episodes"])
            if seed < first + count and first < seed + episodes:
                raise ValueError(
                    f"the held-out seeds {seed}..{seed + episodes - 1} overlap seed {s}'s evaluation seeds during training "
                    f"{first}..{first + count - 1}; choose --seed outside them"
                )


def _goodness(value: float | None, higher_is_better: bool) -> float:
    if value is None or not math.isfinite(value):
        return -math.inf
    return value if higher_is_better else -value


def median_seed(scores: Mapping[int, Mapping[str, float | None]], metric: str = "success") -> int:
    """The median seed by ``metric`` of per-seed ``scores`` (seed -> metric -> score; see the module docstring).

    A missing or non-finite score counts as the worst.
    """
    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}; choose one of {', '.join(METRICS)}")
    if not scores:
        raise ValueError("median_seed() needs at least one seed")
    ties = [m for m in ("time_to_success", "success") if m != metric]

    def order(seed: int) -> tuple[float, ...]:
        s = scores[seed]
        return (*(_goodness(s.get(m), METRICS[m]) for m in (metric, *ties)), -seed)

    ranked = sorted(scores, key=order)  # worst first
    return ranked[(len(ranked) - 1) // 2]


def evaluate_seeds(
    run_dir: str | Path,
    episodes: int = DEFAULT_EPISODES,
    seed: int = DEFAULT_SEED,
    workers: int = 1,
    task: Mapping[str, Any] | None = None,
    *,
    model: str = "final",
    metric: str = "success",
    resamples: int = 2000,
    bootstrap_seed: int = 0,
) -> dict[str, Any]:
    """Evaluate every seed of the run in ``run_dir`` on held-out seeds ``seed ..``; the record of ``seeds.json``."""
    from baselines.rl.compare import OWN_METRICS, compare, episode_values
    from baselines.seed_stats import across_runs

    if metric not in METRICS:
        raise ValueError(f"unknown metric {metric!r}; choose one of {', '.join(METRICS)}")
    paths = read_runs(run_dir, model)
    sidecars = {s: _sidecar(p) for s, p in paths.items()}
    envs = sorted({sc["env"] for sc in sidecars.values()})
    if len(envs) != 1:
        raise ValueError(f"the seeds of {str(run_dir)!r} were trained on different envs: {', '.join(envs)}")
    env_id = envs[0]
    _check_held_out(sidecars, seed, episodes)
    import teamgym

    dt = float(teamgym.make(env_id, **{**sidecars[min(paths)].get("overrides", {}), **(task or {})}).config.dt)
    rows, values = {}, {}
    for s, path in paths.items():
        played: dict[str, list[Any]] = {}
        (row,) = compare(env_id, str(path), episodes, seed, workers, task, policies=[], results=played)
        rows[s] = {**row, "label": f"seed {s}"}
        values[s] = episode_values(played[row["label"]], dt, OWN_METRICS.get(env_id, ()))
    names = [n for n in values[min(paths)] if all(n in v for v in values.values())]
    if metric not in names:
        raise ValueError(f"{env_id} reports no {metric!r} (it has {', '.join(names)})")
    options = {"resamples": resamples, "seed": bootstrap_seed}
    across = {}
    for name in names:
        runs = [values[s][name] for s in paths]
        if any(runs):
            across[name] = across_runs(runs, target=1.0 if name in RATES else None, **options)
    scores = {s: {n: (float(sum(v[n]) / len(v[n])) if v[n] else None) for n in names} for s, v in values.items()}
    median = median_seed(scores, metric)
    return {
        "run_dir": str(run_dir),
        "env": env_id,
        "model": model,
        "held_out": {"seed": seed, "episodes": episodes},
        "task": {k: str(v) for k, v in (task or {}).items()},
        "bootstrap": {"resamples": resamples, "seed": bootstrap_seed, "level": 0.95, "resample": "runs+episodes"},
        "seeds": list(paths),
        "models": {str(s): str(p) for s, p in paths.items()},
        "per_seed": {str(s): rows[s] for s in paths},
        "across_seeds": across,
        "metric": metric,
        "median_seed": median,
        "median_model": str(paths[median]),
    }


def _figure(name: str, value: float | None, digits: int = 2) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    return f"{100 * value:.0f} %" if name in RATES else f"{value:.{digits}f}"


def _interval(name: str, bounds: Sequence[float | None]) -> str:
    low, high = bounds
    if low is None or high is None or not (math.isfinite(low) and math.isfinite(high)):
        return ""
    return f" [{100 * low:.0f}, {100 * high:.0f}]" if name in RATES else f" [{low:.2f}, {high:.2f}]"


def markdown(record: Mapping[str, Any]) -> str:
    """``seeds.md``: the per-seed comparison table and the across-seeds table."""
    from baselines.rl.compare import markdown as rows_table

    median = record["median_seed"]
    rows = [{**row, "label": row["label"] + (" (median)" if int(s) == median else "")} for s, row in record["per_seed"].items()]
    held = record["held_out"]
    lines = [
        f"# {record['env']}: {len(rows)} training seeds of {record['run_dir']}",
        "",
        f"{held['episodes']} held-out seeds from {held['seed']}"
        + (f", task {record['task']}" if record["task"] else "")
        + f"; the {record['model']} model of each seed. Per seed, intervals are over episodes (Wilson for rates).",
        "",
        rows_table(rows),
        "",
        f"Across seeds: per seed its mean over the episodes; IQM and mean of those with 95 % stratified-bootstrap "
        f"intervals over seeds and episodes ({record['bootstrap']['resamples']} resamples, generator seed "
        f"{record['bootstrap']['seed']}).",
        "",
        "| metric | IQM [95 % CI] | mean [95 % CI] | median | per seed | optimality gap [95 % CI] |",
        "|---|---|---|---|---|---|",
    ]
    for name, stats in record["across_seeds"].items():
        per_seed = ", ".join(_figure(name, v) for v in stats["per_run"])
        gap = (
            f"{_figure(name, stats['optimality_gap'])}{_interval(name, stats['optimality_gap_ci'])}"
            if "optimality_gap" in stats
            else "–"
        )
        lines.append(
            f"| {name} | {_figure(name, stats['iqm'])}{_interval(name, stats['iqm_ci'])} | "
            f"{_figure(name, stats['mean'])}{_interval(name, stats['mean_ci'])} | {_figure(name, stats['median'])} | "
            f"{per_seed} | {gap} |"
        )
    lines += ["", f"Median seed by {record['metric']}: seed {median} ({record['median_model']})."]
    return "\n".join(lines)


def sidecar_record(record: Mapping[str, Any]) -> dict[str, Any]:
    """The ``seeds`` field of a shipped agent's sidecar: where it came from and the figures across seeds."""
    per_seed = {
        s: {k: row[k] for k in ("success", "success_ci", "clean_success", "clean_success_ci") if row.get(k) is not None}
        for s, row in record["per_seed"].items()
    }
    keep = ("run_dir", "model", "held_out", "task", "bootstrap", "seeds", "metric", "median_seed")
    return {**{k: record[k] for k in keep}, "per_seed": per_seed, "across_seeds": record["across_seeds"]}


_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


def _ship_targets(name: str, agents_dir: Path, force: bool) -> dict[str, Path]:
    if not _NAME.fullmatch(name) or name.endswith((".zip", ".json")):
        raise ValueError(f"--ship expects an agent name such as navigation-ppo (letters, digits, . _ -), got {name!r}")
    targets = {"zip": agents_dir / f"{name}.zip", "json": agents_dir / f"{name}.json", "csv": agents_dir / f"{name}_eval.csv"}
    if not force:
        existing = [str(p) for p in targets.values() if p.exists()]
        if existing:
            raise ValueError(f"--ship {name}: {existing[0]!r} exists; give --force to replace it")
    return targets


def ship(record: Mapping[str, Any], name: str, agents_dir: str | Path | None = None, force: bool = False) -> Path:
    """Copy the median seed's model, sidecar (with a ``seeds`` field) and ``_eval.csv`` to ``agents_dir/NAME.*``."""
    from baselines.learned import write_sidecar
    from baselines.rl.sb3_policy import AGENT_DIR

    agents_dir = Path(agents_dir) if agents_dir is not None else AGENT_DIR
    targets = _ship_targets(name, agents_dir, force)
    model = Path(record["median_model"])
    csv = _curve_of(model)
    if not csv.is_file():
        raise FileNotFoundError(f"the median seed has no learning curve {str(csv)!r} (train with --eval-every N)")
    sidecar = _sidecar(model)
    agents_dir.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(model, targets["zip"])
    shutil.copyfile(csv, targets["csv"])
    if isinstance(sidecar.get("eval"), dict):
        sidecar["eval"] = {**sidecar["eval"], "csv": targets["csv"].name}
    sidecar.update(model=targets["zip"].name, shipped_from=str(model), seeds=sidecar_record(record))
    write_sidecar(targets["json"], "sb3", sidecar)
    return targets["zip"]


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.rl.seeds`` argument parser (a bad command line exits 2 with a one-line error)."""
    from baselines.cli import Parser, at_least, nonblank
    from baselines.evaluate import MAX_EPISODES

    parser = Parser(prog="python -m baselines.rl.seeds", description=__doc__.splitlines()[0])
    parser.add_argument(
        "run_dir", type=nonblank("a run directory"), metavar="DIR", help="output directory of baselines.train --seeds"
    )
    parser.add_argument(
        "--episodes",
        type=at_least(1, MAX_EPISODES),
        default=DEFAULT_EPISODES,
        help=f"held-out episodes per seed (default: {DEFAULT_EPISODES})",
    )
    parser.add_argument("--seed", type=at_least(0), default=DEFAULT_SEED, help=f"first held-out seed (default: {DEFAULT_SEED})")
    parser.add_argument("--workers", type=at_least(1), default=1, help="worker processes per evaluation (default: 1)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="task config for every seed's model")
    parser.add_argument(
        "--model", choices=("final", "best"), default="final", help="each seed's final or _best model (default: final)"
    )
    parser.add_argument(
        "--metric", choices=list(METRICS), default="success", help="metric choosing the median seed (default: success)"
    )
    parser.add_argument("--resamples", type=at_least(1), default=2000, help="bootstrap resamples (default: 2000)")
    parser.add_argument("--bootstrap-seed", type=at_least(0), default=0, help="bootstrap generator seed (default: 0)")
    parser.add_argument("--curve", action="store_true", help="draw the learning curve across seeds to DIR/curve.png")
    parser.add_argument("--curve-metric", default="success_rate", help="with --curve: eval CSV column (default: success_rate)")
    parser.add_argument(
        "--ship",
        type=nonblank("an agent name"),
        default=None,
        metavar="NAME",
        help="copy the median seed to the shipped agents as NAME",
    )
    parser.add_argument(
        "--agents-dir", type=nonblank("a directory"), default=None, help="with --ship: where to (default: baselines/rl/agents)"
    )
    parser.add_argument("--force", action="store_true", help="with --ship: replace an existing agent NAME")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI: exit 2 with one line for bad input before any episode, 1 for a failure while playing."""
    import teamgym
    from baselines.cli import check_out, guarded, message, parse_args, parse_pairs
    from baselines.rl.sb3_policy import AGENT_DIR

    args = parse_args(build_parser(), argv)
    if isinstance(args, int):
        return args
    try:
        if (args.agents_dir is not None or args.force) and args.ship is None:
            raise ValueError("--agents-dir and --force apply to --ship only")
        if args.curve_metric != "success_rate" and not args.curve:
            raise ValueError("--curve-metric applies to --curve only")
        run_dir = Path(args.run_dir)
        paths = read_runs(run_dir, args.model)
        check_out(run_dir, "DIR")
        task = parse_pairs(args.set, "--set")
        sidecars = {s: _sidecar(p) for s, p in paths.items()}
        _check_held_out(sidecars, args.seed, args.episodes)
        for sidecar in sidecars.values():
            teamgym.make(sidecar["env"], **{**sidecar.get("overrides", {}), **task}).close()
        if args.ship is not None:
            agents_dir = Path(args.agents_dir) if args.agents_dir is not None else AGENT_DIR
            check_out(agents_dir, "--agents-dir")
            _ship_targets(args.ship, agents_dir, args.force)
            missing = [str(_curve_of(p)) for p in paths.values() if not _curve_of(p).is_file()]
            if missing:
                raise FileNotFoundError(
                    f"--ship needs every seed's learning curve; no {missing[0]!r} (train with --eval-every N)"
                )
        if args.curve:
            from baselines.rl.plot_curves import load_curves

            curves = load_curves({run_dir.name or str(run_dir): [_curve_of(p) for p in paths.values()]}, args.curve_metric)
    except (ValueError, KeyError, FileNotFoundError) as error:
        print(f"error: {message(error)}", file=sys.stderr)
        return 2

    def body() -> int:
        from baselines.rl.compare import single_thread_torch

        single_thread_torch()
        record = evaluate_seeds(
            run_dir, args.episodes, args.seed, args.workers, task,
            model=args.model, metric=args.metric, resamples=args.resamples, bootstrap_seed=args.bootstrap_seed,
        )  # fmt: skip
        from baselines.summary import write_json

        table = markdown(record)
        write_json(run_dir / "seeds.json", record)
        (run_dir / "seeds.md").write_text(table + "\n")
        print(table)
        print(f"wrote {run_dir / 'seeds.json'} and {run_dir / 'seeds.md'}")
        if args.curve:
            from baselines.rl.plot_curves import plot_curves

            title = f"{record['env']}, {len(paths)} seeds: IQM of {args.curve_metric} on held-out seeds while training"
            drawn = plot_curves(curves, run_dir / "curve.png", args.curve_metric, ci="bootstrap", title=title, center="iqm")
            print(f"wrote {drawn}")
        if args.ship is not None:
            print(f"shipped seed {record['median_seed']} as {ship(record, args.ship, args.agents_dir, args.force)}")
        return 0

    return guarded(body)


if __name__ == "__main__":
    sys.exit(main())
