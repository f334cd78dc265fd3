"""Summaries of episode results and the files they are written to.

* :func:`summarise`: ``success_rate``, ``mean_episode_length``, ``mean_return``,
  ``mean_<metric>`` for every numeric metric and ``metrics`` (mean/std/min/max/count of each);
* :func:`summary_table` (plain text) and :func:`markdown_table` (Markdown rows);
* :func:`write_summary_json` (``summary.json``, strict JSON), :func:`write_episodes_csv`
  (``episodes.csv``, one row per episode) and :func:`write_json`, through :func:`json_safe`
  (non-finite floats become ``null``; numpy scalars and arrays Python ones).

Metric means pool all (robot, episode) values: a metric a robot does not report is left out
rather than counted as zero; booleans count as 0/1. Categorical metrics are never averaged
(:func:`baselines.episode.metric_names` leaves them out).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from baselines.episode import EpisodeResult, metric_names

__all__ = [
    "json_safe",
    "markdown_table",
    "stats",
    "summarise",
    "summary_table",
    "write_episodes_csv",
    "write_json",
    "write_summary_json",
]


def stats(values: Sequence[float]) -> dict[str, float | int]:
    """``mean``, ``std``, ``min``, ``max`` (NaN when empty) and ``count`` of ``values``."""
    array = np.asarray(values, dtype=float)
    if array.size == 0:
        return {"mean": math.nan, "std": math.nan, "min": math.nan, "max": math.nan, "count": 0}
    with np.errstate(invalid="ignore"):
        return {
            "mean": float(np.mean(array)),
            "std": float(np.std(array)),
            "min": float(np.min(array)),
            "max": float(np.max(array)),
            "count": int(array.size),
        }


def summarise(results: Sequence[EpisodeResult]) -> dict[str, Any]:
    """Aggregate episode results.

    Returns ``episodes``, ``success_rate``, ``mean_episode_length``, ``mean_return`` (mean
    over robots and episodes), ``mean_<metric>`` for every numeric metric (pooled over
    every robot of every episode that reports it) and ``metrics``: per metric (plus
    ``episode_length``, ``return`` and ``success``) its ``mean``, ``std``, ``min``, ``max``
    and ``count``. ``success`` is the episode's (the contract's), so ``mean_success`` equals
    ``success_rate``; it is kept because BoxPushing-v0 summaries had it as a metric.
    """
    if not results:
        raise ValueError("summarise() needs at least one episode result")
    names = metric_names(results)
    table: dict[str, dict[str, float | int]] = {
        "episode_length": stats([r.length for r in results]),
        "return": stats([v for r in results for v in r.returns.values()]),
        "success": stats([float(r.success) for r in results]),
    }
    for name in names:
        table[name] = stats([v for r in results for v in r.metric_values(name)])
    summary: dict[str, Any] = {
        "episodes": len(results),
        "success_rate": float(np.mean([r.success for r in results])),
        "mean_episode_length": table["episode_length"]["mean"],
        "mean_return": table["return"]["mean"],
    }
    summary["mean_success"] = table["success"]["mean"]
    for name in names:
        summary[f"mean_{name}"] = table[name]["mean"]
    summary["metrics"] = table
    return summary


def markdown_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of dict rows (keys of the first row as columns; floats to 3 significant digits)."""
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in rows:
        cells = [f"{row[k]:.3g}" if isinstance(row[k], float) else str(row[k]) for k in keys]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_table(summary: Mapping[str, Any], title: str | None = None) -> str:
    """A plain-text, column-aligned table of a :func:`summarise` result."""

    def fmt(value: Any) -> str:
        if isinstance(value, int):
            return str(value)
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return "-"
        return f"{value:.4g}"

    rows = [
        ("metric", "mean", "std", "min", "max", "n"),
        ("success_rate", fmt(summary["success_rate"]), "", "", "", fmt(summary["episodes"])),
    ]
    for name, s in summary["metrics"].items():
        rows.append((name, fmt(s["mean"]), fmt(s["std"]), fmt(s["min"]), fmt(s["max"]), fmt(s["count"])))
    widths = [max(len(row[c]) for row in rows) for c in range(len(rows[0]))]
    lines = [title] if title else []
    for i, row in enumerate(rows):
        cells = [row[0].ljust(widths[0])] + [cell.rjust(w) for cell, w in zip(row[1:], widths[1:])]
        lines.append("  ".join(cells).rstrip())
        if i == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def json_safe(value: Any) -> Any:
    """Replace non-finite floats with ``None`` (strict JSON) and numpy scalars/tuples with Python ones."""
    if isinstance(value, Mapping):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    return value


def write_json(path: str | Path, data: Mapping[str, Any], *, default: Callable[[Any], Any] | None = None) -> Path:
    """Write ``data`` as strict, indented JSON through :func:`json_safe` (``default``: as ``json.dumps``'s); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(json_safe(data), indent=2, allow_nan=False, default=default) + "\n")
    return path


def write_summary_json(path: str | Path, summary: Mapping[str, Any]) -> Path:
    """Write ``summary`` as strict JSON (non-finite numbers become ``null``)."""
    return write_json(path, summary)


def write_episodes_csv(path: str | Path, results: Sequence[EpisodeResult]) -> Path:
    """One row per episode: ``episode, seed, length, success, return`` and the mean of every metric."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = metric_names(results)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "seed", "length", "success", "return", *names])
        for i, result in enumerate(results):
            means = result.metric_means()
            cells = [repr(means[n]) if n in means else "" for n in names]
            writer.writerow([i, result.seed, result.length, int(result.success), repr(result.mean_return), *cells])
    return path
