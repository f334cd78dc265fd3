"""Checks of ``reset(seed, options)`` input, run before a reset changes anything.

:meth:`TeamEnv.reset` calls :func:`check_seed` and the env's ``_check_reset_options`` first,
so a rejected reset leaves the env as it was (it still pickles and continues).
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterable
from typing import Any

import numpy as np


def check_seed(seed: Any) -> int | None:
    """``seed`` as a Python int (or None); raise naming ``seed`` unless it is a non-negative integer."""
    if seed is None:
        return None
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"reset seed={reprlib.repr(seed)} is invalid; it must be a non-negative int or None")
    if seed < 0:
        raise ValueError(f"reset seed={reprlib.repr(seed)} is invalid; it must be a non-negative int or None")
    return int(seed)


#: The one key every env tolerates (and drops): PettingZoo's conformance tests (``api_test``,
#: ``parallel_api_test``) call ``reset(seed=0, options={"options": 1})`` to check that reset takes options.
PETTINGZOO_PROBE_KEY = "options"


def check_option_keys(env_name: str, options: Any, allowed: Iterable[str]) -> dict:
    """``options`` as a dict (None: empty) without PettingZoo's probe key; raise naming any key not in ``allowed``."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise TypeError(f"reset options must be a dict or None, got {type(options).__name__}")
    allowed = tuple(allowed)
    options = {k: v for k, v in options.items() if k != PETTINGZOO_PROBE_KEY or k in allowed}
    unknown = [k for k in options if k not in allowed]
    if unknown:
        accepted = f"it accepts {list(allowed)}" if allowed else "it accepts none"
        raise ValueError(f"{env_name}.reset: unknown option key(s) {unknown}; {accepted}")
    return dict(options)


def scene_points(key: str, value: Any, shape: tuple[int, ...], size: tuple[float, float], margin: float) -> np.ndarray:
    """Reset option ``key`` as a float array of ``shape`` whose points ``(x, y, ...)`` lie ``margin`` inside ``[0, w] × [0, h]``.

    Rows may carry more columns than the point (a heading θ), which must be finite.
    """
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        array = np.array(np.nan)
    (w, h) = size
    if array.shape == shape and np.all(np.isfinite(array)):
        x, y = array[..., 0], array[..., 1]
        if np.all((x >= margin) & (x <= w - margin) & (y >= margin) & (y <= h - margin)):
            return array
    raise ValueError(
        f"reset option {key!r}={reprlib.repr(value)} is invalid; it must have shape {shape} with finite values and points "
        f"(x, y) at least {margin:g} m inside the {w:g} m × {h:g} m field"
    )
