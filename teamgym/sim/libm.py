"""Element-wise ``math`` functions of numpy arrays with the bits Python's scalar ``math`` gives.

The lone envs compute angles and distances robot by robot with Python's ``math`` (libm's
``atan2``, ``cos``, ``sin``, ``pow``; CPython's own ``hypot`` and ``remainder``). A batch of
copies computes the same values as arrays and must match them bit for bit, but numpy's
versions are not the same functions: its ``hypot`` is not CPython's, it has no IEEE
``remainder``, and on CPUs with AVX-512 its ``arctan2`` and ``power`` kernels differ from libm
in the last bit. :func:`libm` maps the ``math`` function over the elements (one Python call
each); :func:`remainder_tau` is CPython's ``math.remainder(x, τ)`` algorithm in numpy, whose every
step is an exact or identically rounded IEEE operation.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["libm", "remainder_tau"]


def libm(function: Callable[..., float], *values: np.ndarray) -> np.ndarray:
    """``function`` (a ``math`` function) of every element (of every tuple of elements), float64 of the first's shape."""
    flat = [np.asarray(value).ravel().tolist() for value in values]
    first = np.asarray(values[0])
    return np.fromiter(map(function, *flat), dtype=float, count=first.size).reshape(first.shape)


def remainder_tau(values: np.ndarray) -> np.ndarray:
    """``math.remainder(v, τ)`` of every element, bit for bit (CPython's ``m_remainder``: ``fmod``, then the
    half-way rule)."""
    tau = math.tau
    absolute = np.abs(values)
    m = np.fmod(absolute, tau)
    c = tau - m
    halfway = m - 2.0 * np.fmod(0.5 * (absolute - m), tau)
    r = np.where(m < c, m, np.where(m > c, -c, halfway))
    return np.copysign(1.0, values) * r
