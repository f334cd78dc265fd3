"""Confidence intervals for experiment tables: Wilson intervals of rates, normal intervals of means."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a proportion (fractions); ``(nan, nan)`` for ``n = 0``."""
    if n == 0:
        return (math.nan, math.nan)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (centre - half, centre + half)


def mean_ci(values: Sequence[float]) -> dict[str, float]:
    """Mean, 95 % half-width (1.96 standard errors) and count of the finite ``values``."""
    array = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if array.size == 0:
        return {"mean": math.nan, "ci95": math.nan, "n": 0}
    half = 1.96 * float(np.std(array, ddof=1)) / math.sqrt(array.size) if array.size > 1 else math.nan
    return {"mean": float(np.mean(array)), "ci95": half, "n": int(array.size)}


def rate_text(successes: int, n: int) -> str:
    """``"82 % [73, 88]"``: a rate with its Wilson 95 % interval, in percent."""
    if n == 0:
        return "–"
    low, high = wilson(successes, n)
    return f"{100 * successes / n:.0f} % [{100 * low:.0f}, {100 * high:.0f}]"


def mean_text(values: Sequence[float], digits: int = 0) -> str:
    """``"114 ± 12 (n=82)"``: a mean with its 95 % half-width and count; ``"–"`` without values."""
    stats = mean_ci(values)
    if stats["n"] == 0:
        return "–"
    half = "" if math.isnan(stats["ci95"]) else f" ± {stats['ci95']:.{digits}f}"
    return f"{stats['mean']:.{digits}f}{half} (n={stats['n']})"
