"""``baselines.seed_stats``: IQM, stratified bootstrap intervals, optimality gap and probability of improvement,
checked against hand-computed values and the properties they must have."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import trim_mean

from baselines.seed_stats import (
    AGGREGATES,
    across_runs,
    iqm,
    optimality_gap,
    probability_of_improvement,
    run_scores,
    stratified_bootstrap_ci,
)


def test_iqm_by_hand():
    assert iqm([1, 2, 3, 4, 100, 5, 6, 7]) == pytest.approx(4.5)  # the middle 4 of 8: 3, 4, 5, 6
    assert iqm([3, 1, 2]) == pytest.approx((1 + 4 * 2 + 3) / 6)  # 1/12 of 1, 1/3 of 2, 1/12 of 3, over 1/2
    assert iqm([1, 3]) == pytest.approx(2.0)
    assert iqm([7.5]) == 7.5
    # five scores, slices of 1/5: [0.25, 0.75] holds 0.15 of the 2nd, 0.2 of the 3rd, 0.15 of the 4th
    assert iqm([10, 20, 30, 40, 50]) == pytest.approx(2 * (0.15 * 20 + 0.2 * 30 + 0.15 * 40))


def test_iqm_properties():
    rng = np.random.default_rng(0)
    assert iqm([4.2] * 7) == pytest.approx(4.2)  # a constant
    for n in (4, 8, 12, 100):
        values = rng.normal(size=n)
        assert iqm(values) == pytest.approx(trim_mean(values, 0.25))  # a multiple of 4: the middle n/2 scores
    values = rng.normal(size=9)
    assert iqm(values) == pytest.approx(iqm(values[::-1]))  # order does not matter
    assert iqm(values + 3) == pytest.approx(iqm(values) + 3) and iqm(2 * values) == pytest.approx(2 * iqm(values))
    outlier = np.append(values, 1e9)
    assert abs(iqm(outlier) - iqm(values)) < 2  # robust to one wild score, unlike the mean


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        (lambda: iqm([]), "at least one score"),
        (lambda: iqm([1, math.nan]), "must be finite"),
        (lambda: iqm([[1, 2], [3, 4]]), "flat sequence"),
        (lambda: iqm(["a"]), "must be numbers"),
        (lambda: optimality_gap([]), "at least one score"),
        (lambda: optimality_gap([1], math.inf), "target must be finite"),
        (lambda: probability_of_improvement([], [1]), "on each side"),
        (lambda: stratified_bootstrap_ci([]), "non-empty sequence"),
        (lambda: stratified_bootstrap_ci([[], []]), "no episode scores"),
        (lambda: stratified_bootstrap_ci([[1, math.inf]]), "run 0's episode scores must be finite"),
        (lambda: stratified_bootstrap_ci([[1]], level=1.0), "level must be a number in (0, 1)"),
        (lambda: stratified_bootstrap_ci([[1]], resamples=0), "resamples must be an integer >= 1"),
        (lambda: stratified_bootstrap_ci([[1]], resample="seeds"), "resample must be one of"),
    ],
)
def test_bad_input_is_a_one_line_error(call, needle):
    with pytest.raises(ValueError) as error:
        call()
    assert needle in str(error.value) and "\n" not in str(error.value)


def test_optimality_gap_and_probability_of_improvement_by_hand():
    assert optimality_gap([0.5, 1.0, 0.8]) == pytest.approx((0.5 + 0 + 0.2) / 3)
    assert optimality_gap([1.0, 1.0]) == 0.0
    assert optimality_gap([2.0, 0.0], target=1.0) == pytest.approx(0.5)  # a score above the target does not offset
    assert probability_of_improvement([3, 4], [1, 2]) == 1.0
    assert probability_of_improvement([1, 2], [3, 4]) == 0.0
    assert probability_of_improvement([1, 3], [2, 3]) == pytest.approx((0 + 0 + 1 + 0.5) / 4)  # 3 > 2, 3 = 3
    x, y = [0.1, 0.5, 0.7], [0.2, 0.5]
    assert probability_of_improvement(x, y) + probability_of_improvement(y, x) == pytest.approx(1.0)


def test_run_scores_and_aggregates():
    runs = [[1, 0, 1, 1], [0, 0], [], [1]]
    assert run_scores(runs)[:2].tolist() == [0.75, 0.0] and math.isnan(run_scores(runs)[2])
    assert AGGREGATES["mean"](runs) == pytest.approx((0.75 + 0 + 1) / 3)  # the empty run is left out
    assert AGGREGATES["median"](runs) == pytest.approx(0.75)
    assert AGGREGATES["iqm"](runs) == pytest.approx((0 + 4 * 0.75 + 1) / 6)


def test_bootstrap_is_seeded_and_contains_the_estimate():
    rng = np.random.default_rng(1)
    runs = [rng.random(40) < p for p in (0.6, 0.7, 0.9)]
    first = stratified_bootstrap_ci(runs, seed=3, resamples=1000)
    assert first == stratified_bootstrap_ci(runs, seed=3, resamples=1000)  # reproducible
    times = [rng.normal(20 + k, 3, size=30) for k in range(3)]
    assert stratified_bootstrap_ci(times, seed=3, resamples=300) == stratified_bootstrap_ci(times, seed=3, resamples=300)
    assert stratified_bootstrap_ci(times, seed=3, resamples=300) != stratified_bootstrap_ci(times, seed=4, resamples=300)
    estimate, low, high = first
    assert estimate == pytest.approx(AGGREGATES["iqm"](runs))
    assert 0 <= low <= estimate <= high <= 1
    for resample in ("runs", "episodes"):
        _, low2, high2 = stratified_bootstrap_ci(runs, resample=resample, seed=3, resamples=1000)
        assert low2 <= estimate <= high2
        assert high2 - low2 < high - low  # resampling one level only varies less than both


def test_bootstrap_by_hand_and_degenerate_cases():
    # one run: only its episodes vary; the mean of [0, 1] resamples to 0, 0.5 or 1 with probabilities 1/4, 1/2, 1/4
    estimate, low, high = stratified_bootstrap_ci([[0.0, 1.0]], AGGREGATES["mean"], resamples=4000, seed=0)
    assert (estimate, low, high) == (0.5, 0.0, 1.0)
    # one episode per run: only the runs vary (and with resample="episodes" nothing does)
    estimate, low, high = stratified_bootstrap_ci([[0.2], [0.4], [0.9]], AGGREGATES["mean"], seed=0)
    assert estimate == pytest.approx(0.5) and low == pytest.approx(0.2) and high == pytest.approx(0.9)
    assert stratified_bootstrap_ci([[0.2], [0.4]], resample="episodes") == pytest.approx((0.3, 0.3, 0.3))
    assert stratified_bootstrap_ci([[5.0, 5.0], [5.0]]) == (5.0, 5.0, 5.0)  # a constant: a point
    # runs without episodes are left out (resamples drawing only the empty run are dropped)
    estimate, low, high = stratified_bootstrap_ci([[1.0, 1.0], []], AGGREGATES["mean"], seed=0)
    assert estimate == 1.0 and low == high == 1.0


def test_across_runs_record():
    runs = [[1, 1, 0, 1], [1, 0, 0, 0], [1, 1, 1, 1]]
    record = across_runs(runs, target=1.0, resamples=500, seed=7)
    assert record["runs"] == 3 and record["episodes"] == [4, 4, 4] and record["level"] == 0.95
    assert record["per_run"] == [0.75, 0.25, 1.0]
    assert record["iqm"] == pytest.approx((0.25 + 4 * 0.75 + 1.0) / 6)
    assert record["mean"] == pytest.approx(2 / 3) and record["median"] == 0.75
    assert record["optimality_gap"] == pytest.approx((0.25 + 0.75 + 0) / 3)
    for name in ("iqm", "mean", "optimality_gap"):
        low, high = record[f"{name}_ci"]
        assert low <= record[name] <= high
    assert across_runs(runs, target=1.0, resamples=500, seed=7) == record
    assert "optimality_gap" not in across_runs(runs, resamples=10)
