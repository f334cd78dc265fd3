"""Learning curves across seeds from the eval CSVs of ``python -m baselines.train --eval-every N``.

Command line::

    python -m baselines.rl.plot_curves RUN_DIR [RUN_DIR ...] [--metric success_rate]
        [--baseline goto] [--baseline random=path/summary.json] [--ci t|bootstrap|minmax]
        [--center mean|iqm] [--out curve.png] [--title TEXT] [--workers W]

Each ``RUN_DIR`` (or ``*_eval.csv`` file) is one curve; every ``*_eval.csv`` beneath it is
one seed. A ``RUN_DIR`` named ``seed<k>`` joins its siblings: ``plot_curves runs/ppo/seed*``
draws one curve, like ``plot_curves runs/ppo``. Seeds evaluated at the same timesteps are
compared there; otherwise each seed is interpolated linearly onto the timesteps they all cover.

The curve is the mean over seeds (``--center mean``, default) or their interquartile mean
(``--center iqm``: :func:`baselines.seed_stats.iqm`), with a band across seeds: ``--ci t``
(default; the mean only) is the 95 % normal approximation with Student's t quantile,
mean ± t(0.975, n-1)·s/√n, which is honest for the few seeds RL runs have; ``--ci bootstrap``
is the 95 % percentile bootstrap of the centre line over seeds (2000 resamples, fixed generator
seed); ``--ci minmax`` spans the lowest to the highest seed. One seed draws no band.

``--baseline NAME`` draws NAME's value of the metric as a horizontal line, computed with
:func:`baselines.evaluate.evaluate` on the runs' held-out seeds, episodes, env and config
(read from the model sidecar ``<stem>.json`` beside the first ``<stem>_eval.csv``);
``--baseline NAME=SUMMARY.json`` reads it from a ``baselines.evaluate`` summary instead
(a note goes to stderr when its env, seeds or episodes differ from the runs').

The printed table gives, per curve, the final value of every seed (its last evaluation),
their mean with the 95 % interval above, and the interquartile mean across seeds as in
rliable (Agarwal et al., 2021): the mean of the middle 50 % (:func:`baselines.seed_stats.iqm`,
the slice [0.25, 0.75] of the seeds' empirical distribution: for 3 sorted seeds ``a, b, c``
``(a + 4b + c)/6``) with a 95 % percentile-bootstrap interval over seeds (2000 resamples).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "Curve",
    "aggregate",
    "baseline_value",
    "centre_line",
    "bootstrap_interval",
    "build_parser",
    "confidence_band",
    "find_eval_csvs",
    "group_runs",
    "interquartile_mean",
    "load_curve",
    "main",
    "plot_curves",
    "run_settings",
    "summary_rows",
]

BOOTSTRAP_RESAMPLES = 2000


def find_eval_csvs(path: str | Path) -> list[Path]:
    """The eval CSVs of ``path``: the file itself, or every ``*_eval.csv`` beneath a directory (sorted)."""
    path = Path(path)
    if path.is_file():
        return [path]
    if not path.is_dir():
        raise FileNotFoundError(f"no such run directory or file: {str(path)!r}")
    return sorted(path.rglob("*_eval.csv"))


def group_runs(paths: Sequence[str | Path]) -> dict[str, list[Path]]:
    """Curve label -> its seeds' eval CSVs; a ``seed<k>`` directory is grouped under its parent.

    The label is the directory's name, or its path where two curves' directories share a name.
    """
    groups: dict[Path, list[Path]] = {}
    for item in paths:
        path = Path(item)
        key = path.parent if path.is_file() else path
        if re.fullmatch(r"seed\d+", key.name):
            key = key.parent
        csvs = find_eval_csvs(path)
        if not csvs:
            raise FileNotFoundError(f"no *_eval.csv under {str(path)!r} (train with --eval-every N)")
        members = groups.setdefault(key.resolve(), [])
        members += [c for c in csvs if c not in members]
    names = [key.name for key in groups]
    return {(key.name if names.count(key.name) == 1 and key.name else str(key)): csvs for key, csvs in groups.items()}


def load_curve(path: str | Path, metric: str) -> tuple[np.ndarray, np.ndarray]:
    """Timesteps and ``metric`` of one eval CSV, sorted by timestep (rows without the metric left out)."""
    from baselines.rl.callbacks import EvalLog

    rows = EvalLog.read_rows(path)
    if rows and not any(metric in r for r in rows):
        columns = sorted({k for r in rows for k in r} - {"timesteps"})
        raise ValueError(f"{str(path)!r} has no column {metric!r}; it has {', '.join(columns)}")
    pairs = sorted((r["timesteps"], r[metric]) for r in rows if metric in r)
    if not pairs:
        raise ValueError(f"{str(path)!r} has no evaluation rows")
    t, y = zip(*pairs)
    return np.asarray(t, dtype=float), np.asarray(y, dtype=float)


def aggregate(curves: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Common timesteps and a (seeds × timesteps) array of values.

    Seeds with identical timesteps are stacked as they are; otherwise each is interpolated
    linearly onto the union of their timesteps within the range every seed covers.
    """
    if not curves:
        raise ValueError("no curves to aggregate")
    first = curves[0][0]
    if all(len(t) == len(first) and np.array_equal(t, first) for t, _ in curves):
        return first, np.stack([y for _, y in curves])
    low, high = max(t.min() for t, _ in curves), min(t.max() for t, _ in curves)
    if low > high:
        raise ValueError("the seeds' evaluations cover no common range of timesteps")
    grid = np.unique(np.concatenate([t[(t >= low) & (t <= high)] for t, _ in curves]))
    return grid, np.stack([np.interp(grid, t, y) for t, y in curves])


def bootstrap_interval(
    values: Sequence[float], statistic: Callable[[np.ndarray], float], level: float = 0.95, seed: int = 0
) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``statistic`` over ``values`` (nan for fewer than 2 values)."""
    array = np.asarray(values, dtype=float)
    if array.size < 2:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    samples = array[rng.integers(0, array.size, size=(BOOTSTRAP_RESAMPLES, array.size))]
    stats = np.array([statistic(s) for s in samples])
    alpha = (1 - level) / 2
    return float(np.quantile(stats, alpha)), float(np.quantile(stats, 1 - alpha))


#: The centre lines of a curve across seeds (``--center``).
CENTERS: dict[str, Callable[[np.ndarray], float]] = {"mean": np.mean, "iqm": lambda v: interquartile_mean(v)}
#: The bands across seeds (``--ci``) and the centres each may go with.
BANDS: dict[str, tuple[str, ...]] = {"t": ("mean",), "bootstrap": ("mean", "iqm"), "minmax": ("mean", "iqm")}


def centre_line(values: np.ndarray, center: str = "mean") -> np.ndarray:
    """Per column of a (seeds × timesteps) array, its ``center`` over seeds (``"mean"`` or ``"iqm"``)."""
    if center not in CENTERS:
        raise ValueError(f"unknown centre {center!r}; choose one of {', '.join(CENTERS)}")
    values = np.asarray(values, dtype=float)
    return np.array([CENTERS[center](values[:, j]) for j in range(values.shape[1])])


def confidence_band(
    values: np.ndarray, method: str = "t", level: float = 0.95, center: str = "mean"
) -> tuple[np.ndarray, np.ndarray]:
    """Per-column band of a (seeds × timesteps) array: ``"t"``, ``"bootstrap"`` (of ``center``) or ``"minmax"``."""
    if method not in BANDS:
        raise ValueError(f"unknown interval method {method!r}; choose {', '.join(BANDS)}")
    if center not in BANDS[method]:
        raise ValueError(f"--ci {method} is an interval of the mean; use --ci bootstrap or minmax with --center {center}")
    values = np.asarray(values, dtype=float)
    n = values.shape[0]
    if n < 2:
        nan = np.full(values.shape[1], math.nan)
        return nan, nan.copy()
    if method == "minmax":
        return values.min(axis=0), values.max(axis=0)
    if method == "t":
        from scipy.stats import t as student

        mean = values.mean(axis=0)
        half = student.ppf(0.5 + level / 2, n - 1) * values.std(axis=0, ddof=1) / math.sqrt(n)
        return mean - half, mean + half
    bounds = [bootstrap_interval(values[:, j], CENTERS[center], level) for j in range(values.shape[1])]
    return np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])


def interquartile_mean(values: Sequence[float]) -> float:
    """The mean of the middle 50 % of ``values`` (:func:`baselines.seed_stats.iqm`); ``nan`` for none."""
    from baselines.seed_stats import iqm

    return iqm(values) if len(values) else math.nan


def run_settings(csv_path: str | Path) -> dict[str, Any] | None:
    """The model sidecar beside an eval CSV (``<stem>.json`` for ``<stem>_eval.csv``), or ``None`` if there is none.

    Read as :mod:`baselines.learned` reads sidecars (``ValueError`` naming the file and field for a bad one).
    """
    from baselines.learned import read_sidecar_file

    csv_path = Path(csv_path)
    if not csv_path.name.endswith("_eval.csv"):
        return None
    return read_sidecar_file(csv_path.with_name(csv_path.name[: -len("_eval.csv")] + ".json"), "sb3")


def _eval_settings(settings: Mapping[str, Any]) -> tuple[str, dict[str, str], int, int] | None:
    """``(env, overrides, first seed, episodes)`` of a run's periodic evaluation, from its sidecar."""
    evaluation = settings.get("eval")
    if not isinstance(evaluation, dict) or not isinstance(settings.get("env"), str):
        return None
    overrides = settings.get("overrides") if isinstance(settings.get("overrides"), dict) else {}
    return settings["env"], dict(overrides), int(evaluation["seed"]), int(evaluation["episodes"])


def baseline_value(
    spec: str, metric: str, settings: tuple[str, dict[str, str], int, int] | None, workers: int = 1
) -> tuple[str, float, str]:
    """``(name, value, how it was obtained)`` of one ``--baseline NAME`` or ``NAME=SUMMARY.json``."""
    name, sep, summary_path = spec.partition("=")
    name = name.strip()
    if not name:
        raise ValueError(f"--baseline expects NAME or NAME=SUMMARY.json, got {spec!r}")
    if sep:
        try:
            summary = json.loads(Path(summary_path).read_text())
        except (OSError, ValueError) as error:
            raise ValueError(f"cannot read --baseline {name}'s summary {summary_path!r}: {error}") from None
        if not isinstance(summary, dict) or metric not in summary:
            raise ValueError(f"the summary {summary_path!r} has no {metric!r}")
        if settings is not None:
            env, _, seed, episodes = settings
            theirs = (summary.get("env"), summary.get("seed"), summary.get("episodes"))
            if theirs != (env, seed, episodes):
                print(
                    f"note: --baseline {name}: {summary_path} is env {theirs[0]}, seed {theirs[1]}, {theirs[2]} episodes; "
                    f"the runs were evaluated on {env}, seed {seed}, {episodes} episodes",
                    file=sys.stderr,
                )
        value = summary[metric]
        return name, math.nan if value is None else float(value), summary_path
    if settings is None:
        raise ValueError(f"--baseline {name}: the runs have no model sidecar with evaluation settings; give {name}=SUMMARY.json")
    from baselines.evaluate import evaluate
    from baselines.summary import summarise

    env, overrides, seed, episodes = settings
    summary = summarise(evaluate(env, name, episodes, seed, overrides, workers))
    if metric not in summary:
        raise ValueError(f"policy {name!r} reports no {metric!r} on {env}")
    return name, float(summary[metric]), f"evaluate({env}, seeds {seed}..{seed + episodes - 1})"


@dataclass
class Curve:
    """One curve: its label, seeds' CSVs, common timesteps and (seeds × timesteps) values, final values per seed."""

    label: str
    csvs: list[Path]
    timesteps: np.ndarray
    values: np.ndarray
    finals: np.ndarray
    final_timesteps: np.ndarray


def load_curves(groups: Mapping[str, Sequence[Path]], metric: str) -> list[Curve]:
    """:class:`Curve` of every group of eval CSVs."""
    curves = []
    for label, csvs in groups.items():
        seeds = [load_curve(c, metric) for c in csvs]
        timesteps, values = aggregate(seeds)
        finals = np.array([y[-1] for _, y in seeds])
        curves.append(Curve(label, list(csvs), timesteps, values, finals, np.array([t[-1] for t, _ in seeds])))
    return curves


def summary_rows(curves: Sequence[Curve], baselines: Sequence[tuple[str, float, str]], ci: str = "t") -> list[dict[str, Any]]:
    """Table rows: per curve the final values, their mean with its interval, the IQM with its bootstrap interval."""
    rows = []
    for curve in curves:
        low, high = confidence_band(curve.finals[:, None], ci)
        iqm_low, iqm_high = bootstrap_interval(curve.finals, interquartile_mean)
        steps = sorted({int(t) for t in curve.final_timesteps})
        rows.append(
            {
                "run": curve.label,
                "seeds": len(curve.csvs),
                "timesteps": str(steps[0]) if len(steps) == 1 else f"{steps[0]}-{steps[-1]}",
                "mean": float(np.mean(curve.finals)),
                "ci95": (float(low[0]), float(high[0])),
                "iqm": interquartile_mean(curve.finals),
                "iqm_ci95": (iqm_low, iqm_high),
                "finals": [float(v) for v in curve.finals],
            }
        )
    for name, value, source in baselines:
        rows.append({"run": f"{name} (baseline)", "seeds": "-", "timesteps": "-", "mean": value, "source": source})
    return rows


def format_table(rows: Sequence[Mapping[str, Any]], metric: str, ci: str) -> str:
    """A column-aligned text table of :func:`summary_rows`."""

    def num(value: float) -> str:
        return "-" if value is None or not math.isfinite(value) else f"{value:.3g}"

    def interval(bounds: tuple[float, float] | None) -> str:
        return "-" if bounds is None or not all(math.isfinite(b) for b in bounds) else f"[{num(bounds[0])}, {num(bounds[1])}]"

    band = "min-max" if ci == "minmax" else f"95% CI ({ci})"
    header = ("run", "seeds", "timesteps", f"final {metric}", band, "IQM", "IQM 95% CI", "per seed / source")
    table = [header]
    for row in rows:
        detail = " ".join(num(v) for v in row["finals"]) if "finals" in row else row.get("source", "")
        table.append(
            (
                str(row["run"]),
                str(row["seeds"]),
                str(row["timesteps"]),
                num(row["mean"]),
                interval(row.get("ci95")),
                num(row["iqm"]) if "iqm" in row else "-",
                interval(row.get("iqm_ci95")),
                detail,
            )
        )
    widths = [max(len(r[c]) for r in table) for c in range(len(header))]
    lines = []
    for i, row in enumerate(table):
        lines.append("  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip())
        if i == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def plot_curves(
    curves: Sequence[Curve],
    path: str | Path,
    metric: str = "success_rate",
    baselines: Sequence[tuple[str, float, str]] = (),
    ci: str = "t",
    title: str | None = None,
    center: str = "mean",
) -> Path:
    """Draw each curve's ``center`` over seeds with its band ``ci`` (and faint per-seed lines), baselines as horizontal lines."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure = Figure(figsize=(7, 4.5), dpi=120)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot(1, 1, 1)
    colours = [f"C{i}" for i in range(10)]
    for i, curve in enumerate(curves):
        colour = colours[i % len(colours)]
        for seed_values in curve.values:
            axes.plot(curve.timesteps, seed_values, color=colour, alpha=0.2, linewidth=0.8)
        line = centre_line(curve.values, center)
        axes.plot(curve.timesteps, line, color=colour, linewidth=2, label=f"{curve.label} ({len(curve.csvs)} seeds)")
        low, high = confidence_band(curve.values, ci, center=center)
        if np.isfinite(low).any():
            axes.fill_between(curve.timesteps, low, high, color=colour, alpha=0.2, linewidth=0)
    for j, (name, value, _) in enumerate(baselines):
        if math.isfinite(value):
            colour = colours[(len(curves) + j) % len(colours)]
            axes.axhline(value, color=colour, linestyle="--", linewidth=1.2, label=f"{name}: {value:.3g}")
    axes.set_xlabel("timesteps (agent transitions)")
    axes.set_ylabel(metric)
    if metric == "success_rate":
        axes.set_ylim(-0.02, 1.02)
    band = "min-max" if ci == "minmax" else f"95% CI ({ci})"
    axes.set_title(title or f"{metric}: {'IQM' if center == 'iqm' else 'mean'} over seeds, {band}")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8, loc="best")
    figure.tight_layout()
    figure.savefig(path)
    return path


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m baselines.rl.plot_curves`` argument parser (a bad command line exits 2 with a one-line error)."""
    from baselines.cli import Parser, at_least

    parser = Parser(prog="python -m baselines.rl.plot_curves", description="Plot learning curves across seeds.")
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run directory (or *_eval.csv); one curve each")
    parser.add_argument("--metric", default="success_rate", help="eval CSV column to plot (default: success_rate)")
    parser.add_argument(
        "--baseline",
        action="append",
        default=[],
        metavar="NAME[=SUMMARY.json]",
        help="scripted policy drawn as a horizontal line (repeatable)",
    )
    parser.add_argument(
        "--ci", choices=tuple(BANDS), default="t", help="band across seeds: 95%% t or bootstrap interval, or min-max (default: t)"
    )
    parser.add_argument("--center", choices=tuple(CENTERS), default="mean", help="centre line over seeds (default: mean)")
    parser.add_argument("--out", default="curve.png", help="PNG file to write (default: curve.png)")
    parser.add_argument("--title", default=None, help="plot title")
    parser.add_argument("--workers", type=at_least(1), default=1, help="processes for baseline evaluations (default: 1)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (2 with one line for a bad command line or input, 1 for a failure)."""
    from baselines.cli import message, parse_args

    args = parse_args(build_parser(), argv)
    if isinstance(args, int):  # --help, or a usage error already reported in one line
        return args
    try:
        confidence_band(np.zeros((1, 1)), args.ci, center=args.center)  # --ci t with --center iqm fails here
        out = Path(args.out)
        if out.is_dir():
            raise ValueError(f"--out {str(out)!r} is a directory; name a .png file")
        groups = group_runs(args.runs)
        curves = load_curves(groups, args.metric)
        first = next(iter(groups.values()))[0]
        settings = run_settings(first)
        eval_settings = _eval_settings(settings) if settings else None
        every = [_eval_settings(s) for c in groups.values() for s in map(run_settings, c) if s]
        if args.baseline and any(other != eval_settings for other in every):
            print(f"note: the runs were not all evaluated alike; baselines use the settings of {first}", file=sys.stderr)
        baselines = [baseline_value(spec, args.metric, eval_settings, args.workers) for spec in args.baseline]
    except (ValueError, KeyError, FileNotFoundError, TypeError, ImportError) as error:
        print(f"error: {message(error)}", file=sys.stderr)
        return 2
    except Exception as error:  # noqa: BLE001 - no traceback reaches a command-line user
        if os.environ.get("TEAMGYM_TRACEBACK"):
            raise
        print(f"error: {type(error).__name__}: {message(error)} (TEAMGYM_TRACEBACK=1 shows where)", file=sys.stderr)
        return 1
    path = plot_curves(curves, out, args.metric, baselines, args.ci, args.title, args.center)
    print(format_table(summary_rows(curves, baselines, args.ci), args.metric, args.ci))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
