"""Random scenes of Navigation-v0: robot starts, headings, goals and obstacles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


class PlacementError(RuntimeError):
    """Robots, goals or obstacles could not be placed without overlap."""


@dataclass(frozen=True)
class NavigationScene:
    """A sampled initial scene: robot starts, headings and goals, and obstacles."""

    starts: np.ndarray
    headings: np.ndarray
    goals: np.ndarray
    obstacles: list[tuple[list, tuple, tuple]]


def scatter(
    rng: np.random.Generator, count: int, size: float, margin: float, separation: float, avoid: np.ndarray | None = None
) -> np.ndarray:
    """``count`` random points in ``[margin, size - margin]²``, pairwise (and from ``avoid``) ``separation`` apart."""
    points = np.zeros((count, 2))
    for i in range(count):
        for _ in range(10_000):
            p = rng.uniform(margin, size - margin, size=2)
            if i and np.min(np.linalg.norm(points[:i] - p, axis=1)) < separation:
                continue
            if avoid is not None and len(avoid) and np.min(np.linalg.norm(avoid - p, axis=1)) < separation:
                continue
            points[i] = p
            break
        else:
            raise PlacementError(
                f"could not place {count} objects {separation:.3f} m apart in a {size} m arena; it is too crowded"
            )
    return points
