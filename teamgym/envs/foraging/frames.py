"""Plane vectors between the field frame and the robots' frames, for many robots at once.

Both functions take vectors ``(n, 2)`` and the cos ``c`` and sin ``s`` ``(n,)`` of each
robot's heading, and compute every component as the two products and one sum of the
textbook formula (no matrix product, whose summation order and fused multiply-adds are not
fixed), so results do not depend on how many robots there are.
"""

from __future__ import annotations

import numpy as np

__all__ = ["to_field", "to_robot"]


def to_robot(vectors: np.ndarray, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Field-frame ``(x, y)`` rows in each robot's frame: ``(c·x + s·y, c·y − s·x)``."""
    out = vectors * c[:, None]
    swapped = vectors[:, ::-1] * s[:, None]
    out[:, 0] += swapped[:, 0]
    out[:, 1] -= swapped[:, 1]
    return out


def to_field(vectors: np.ndarray, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Robot-frame ``(x, y)`` rows in the field frame: ``(c·x − s·y, c·y + s·x)``."""
    out = vectors * c[:, None]
    swapped = vectors[:, ::-1] * s[:, None]
    out[:, 0] -= swapped[:, 0]
    out[:, 1] += swapped[:, 1]
    return out
