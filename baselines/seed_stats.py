"""Results across training seeds, after rliable (Agarwal et al., 2021, "Deep RL at the edge of the statistical precipice").

Written from the definitions (no rliable code):

* :func:`iqm`: the **interquartile mean**, the mean of the middle 50 % of the scores: the
  empirical distribution of ``n`` sorted scores gives each score the quantile slice
  ``[(i-1)/n, i/n]``; the IQM is the mean over the slice ``[0.25, 0.75]``, a score cut by its
  edge counting with the part inside. For ``n`` a multiple of 4 that is the mean of the middle
  ``n/2`` scores (``scipy.stats.trim_mean(x, 0.25)``); for 3 sorted scores ``a, b, c`` it is
  ``(a + 4b + c) / 6``, for 2 or 1 the mean. (``trim_mean`` would trim nothing below 4 scores.)
* :func:`stratified_bootstrap_ci`: a percentile bootstrap over **runs** (training seeds) and
  **episodes**: each resample draws the runs with replacement, then within each drawn run its
  episodes with replacement (the run is the stratum of its episodes, so every resampled run
  keeps its number of episodes), and applies the statistic; the interval is the 2.5 and 97.5
  percentiles of the resampled statistics. A fixed generator ``seed`` makes it reproducible.
  With one run only its episodes vary; with one episode per run only the runs do.
* :func:`across_runs`: the per-run score is the run's mean over its episodes (its success rate,
  its mean time, ...); the point estimate is the IQM (or mean, median) of the per-run scores.
  Scores are *per run*, not pooled over runs × episodes: a pooled IQM of 0/1 successes is the
  middle of a sorted list of zeros and ones, not a rate.
* :func:`optimality_gap` (the mean shortfall below a target, ``mean(max(target - x, 0))``) and
  :func:`probability_of_improvement` (``P(X > Y) + P(X = Y) / 2`` for a score ``X`` of one
  algorithm's runs and ``Y`` of another's: the Mann-Whitney statistic over ``n·m``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = [
    "AGGREGATES",
    "BOOTSTRAP_RESAMPLES",
    "across_runs",
    "iqm",
    "optimality_gap",
    "probability_of_improvement",
    "run_scores",
    "stratified_bootstrap_ci",
]

#: Resamples of :func:`stratified_bootstrap_ci` unless told.
BOOTSTRAP_RESAMPLES = 2000
#: What may be resampled: runs, episodes within runs, or both (the default).
RESAMPLING = ("runs+episodes", "runs", "episodes")


def _scores(values: Sequence[float], what: str) -> np.ndarray:
    """``values`` as a 1-D float array of finite numbers, or a one-line ``ValueError`` naming ``what``."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be numbers, got {values!r}") from None
    if array.ndim != 1:
        raise ValueError(f"{what} must be a flat sequence of numbers, got an array of shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{what} must be finite, got {array[~np.isfinite(array)][0]!r}")
    return array


def iqm(values: Sequence[float]) -> float:
    """The interquartile mean of ``values`` (the mean of their middle 50 %; see the module docstring).

    ``ValueError`` for no values or a non-finite one.
    """
    array = np.sort(_scores(values, "iqm() scores"))
    n = array.size
    if n == 0:
        raise ValueError("iqm() needs at least one score")
    edges = np.arange(n + 1) / n
    weights = np.diff(np.clip(edges, 0.25, 0.75)) * 2.0  # each score's share of the slice [0.25, 0.75]
    return float(weights @ array)


def optimality_gap(values: Sequence[float], target: float = 1.0) -> float:
    """The mean shortfall of ``values`` below ``target``: ``mean(max(target - x, 0))`` (0: every score reaches it)."""
    array = _scores(values, "optimality_gap() scores")
    if array.size == 0:
        raise ValueError("optimality_gap() needs at least one score")
    if not math.isfinite(target):
        raise ValueError(f"optimality_gap() target must be finite, got {target!r}")
    return float(np.mean(np.maximum(target - array, 0.0)))


def probability_of_improvement(x: Sequence[float], y: Sequence[float]) -> float:
    """``P(X > Y) + P(X = Y) / 2`` for ``X`` drawn from the scores ``x`` and ``Y`` from ``y`` (higher is better)."""
    a, b = _scores(x, "probability_of_improvement() x"), _scores(y, "probability_of_improvement() y")
    if a.size == 0 or b.size == 0:
        raise ValueError("probability_of_improvement() needs at least one score on each side")
    greater = (a[:, None] > b[None, :]).sum()
    ties = (a[:, None] == b[None, :]).sum()
    return float((greater + 0.5 * ties) / (a.size * b.size))


def run_scores(runs: Sequence[Sequence[float]]) -> np.ndarray:
    """Each run's mean over its episodes (``nan`` for a run with none)."""
    return np.array([float(np.mean(r)) if len(r) else math.nan for r in runs])


def _finite(scores: np.ndarray) -> np.ndarray:
    return scores[np.isfinite(scores)]


#: Statistics across runs of per-run scores (:func:`run_scores`); runs without episodes are left out.
AGGREGATES: dict[str, Callable[[Sequence[Sequence[float]]], float]] = {
    "iqm": lambda runs: iqm(s) if (s := _finite(run_scores(runs))).size else math.nan,
    "mean": lambda runs: float(np.mean(s)) if (s := _finite(run_scores(runs))).size else math.nan,
    "median": lambda runs: float(np.median(s)) if (s := _finite(run_scores(runs))).size else math.nan,
}


def _check_runs(runs: Sequence[Sequence[float]]) -> list[np.ndarray]:
    if isinstance(runs, (str, bytes)) or not isinstance(runs, Sequence) or len(runs) == 0:
        raise ValueError(f"runs must be a non-empty sequence of per-run episode scores, got {runs!r}")
    checked = [_scores(run, f"run {i}'s episode scores") for i, run in enumerate(runs)]
    if not any(run.size for run in checked):
        raise ValueError("runs hold no episode scores at all")
    return checked


def stratified_bootstrap_ci(
    runs: Sequence[Sequence[float]],
    statistic: Callable[[Sequence[np.ndarray]], float] = AGGREGATES["iqm"],
    *,
    level: float = 0.95,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = 0,
    resample: str = "runs+episodes",
) -> tuple[float, float, float]:
    """``(estimate, low, high)``: ``statistic(runs)`` and its percentile-bootstrap interval at ``level``.

    ``runs`` holds one sequence of episode scores per run (lengths may differ; a run may be empty).
    ``resample``: ``"runs+episodes"`` (runs with replacement, then episodes within each drawn run),
    ``"runs"`` or ``"episodes"`` (within every run). Resamples whose statistic is ``nan`` (every drawn
    run empty) are left out; if all are, the interval is ``(nan, nan)``. ``seed`` seeds the generator.
    One-line ``ValueError`` for bad input, before any resampling.
    """
    checked = _check_runs(runs)
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not 0 < level < 1:
        raise ValueError(f"level must be a number in (0, 1), got {level!r}")
    if isinstance(resamples, bool) or not isinstance(resamples, int) or resamples < 1:
        raise ValueError(f"resamples must be an integer >= 1, got {resamples!r}")
    if resample not in RESAMPLING:
        raise ValueError(f"resample must be one of {', '.join(RESAMPLING)}, got {resample!r}")
    estimate = float(statistic(checked))
    rng = np.random.default_rng(seed)
    n = len(checked)
    draw_runs = resample != "episodes" and n > 1
    draw_episodes = resample != "runs"
    values = np.empty(resamples)
    for k in range(resamples):
        picked = [checked[i] for i in rng.integers(0, n, size=n)] if draw_runs else checked
        if draw_episodes:
            picked = [run[rng.integers(0, run.size, size=run.size)] if run.size else run for run in picked]
        values[k] = statistic(picked)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return estimate, math.nan, math.nan
    alpha = (1 - level) / 2
    return estimate, float(np.quantile(values, alpha)), float(np.quantile(values, 1 - alpha))


def across_runs(
    runs: Sequence[Sequence[float]],
    *,
    target: float | None = None,
    level: float = 0.95,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = 0,
) -> dict[str, Any]:
    """One metric across runs: per-run scores, IQM and mean with stratified-bootstrap intervals (``*_ci`` at ``level``), median.

    With ``target`` (e.g. 1.0 for a success rate) also the optimality gap of the per-run scores
    with its interval. Every interval uses the same generator seed, so the record is reproducible.
    """
    checked = _check_runs(runs)
    options: Mapping[str, Any] = {"level": level, "resamples": resamples, "seed": seed}
    scores = run_scores(checked)
    record: dict[str, Any] = {
        "runs": len(checked),
        "level": level,
        "episodes": [int(r.size) for r in checked],
        "per_run": [None if not math.isfinite(s) else float(s) for s in scores],
    }
    for name in ("iqm", "mean"):
        estimate, low, high = stratified_bootstrap_ci(checked, AGGREGATES[name], **options)
        record[name], record[f"{name}_ci"] = estimate, [low, high]
    record["median"] = AGGREGATES["median"](checked)
    if target is not None:

        def gap(sample: Sequence[np.ndarray]) -> float:
            finite = _finite(run_scores(sample))
            return optimality_gap(finite, target) if finite.size else math.nan

        estimate, low, high = stratified_bootstrap_ci(checked, gap, **options)
        record["optimality_gap"], record["optimality_gap_ci"], record["target"] = estimate, [low, high], target
    return record
