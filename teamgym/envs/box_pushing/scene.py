"""Geometry of the box-pushing table: the goal wall, box gaps and free-spot sampling.

The table is ``[0, W] × [0, H]`` enclosed by walls; the goal is the wall nearest the lamp
(paper 004, section 2.1). A box *touches* the goal when its nearest corner is within
``goal_tolerance`` of that wall.
"""

from __future__ import annotations

import math

import numpy as np

from teamgym.envs.config import ConfigError

#: Unit corners of a square box (multiply by half the side).
_CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


class GoalWall:
    """Signed gaps from box corners to the goal wall (``"east"``, ``"west"``, ``"north"``, ``"south"``)."""

    def __init__(self, side: str, width: float, height: float) -> None:
        if side not in ("east", "west", "north", "south"):
            raise ValueError(f"unknown goal side {side!r}")
        self.side = side
        self.axis = 0 if side in ("east", "west") else 1
        self.sign = 1.0 if side in ("east", "north") else -1.0
        self.offset = (width if side == "east" else height) if self.sign > 0 else 0.0

    def gaps(self, poses: np.ndarray, half_sizes: np.ndarray) -> np.ndarray:
        """Gap (m) between each square box ``(x, y, angle)`` (the last axis of ``poses``) of half side ``h`` and the goal wall."""
        if poses.size == 0:
            return np.zeros(poses.shape[:-1])
        c, s = np.cos(poses[..., 2]), np.sin(poses[..., 2])
        # Largest corner extent along the goal axis: h·(|cos| + |sin|) for a square.
        extent = half_sizes * (np.abs(c) + np.abs(s))
        centre = poses[..., self.axis]
        return self.sign * (self.offset - centre) - extent

    def segment(self, width: float, height: float) -> tuple[tuple[float, float], tuple[float, float]]:
        """End points of the goal wall's inner face (for drawing)."""
        if self.side == "east":
            return (width, 0.0), (width, height)
        if self.side == "west":
            return (0.0, 0.0), (0.0, height)
        if self.side == "north":
            return (0.0, height), (width, height)
        return (0.0, 0.0), (width, 0.0)


def box_corners(x: float, y: float, angle: float, half: float) -> np.ndarray:
    """The four corners of a square box in world coordinates."""
    c, s = math.cos(angle), math.sin(angle)
    rotation = np.array([[c, -s], [s, c]])
    return (_CORNERS * half) @ rotation.T + np.array([x, y])


class Placer:
    """Samples non-overlapping spots for discs (robots) and square boxes on the table.

    ``occupied`` holds ``(x, y, radius)`` bounding circles; a new object must keep
    ``clearance`` from each of them and its own margin from the walls.
    """

    def __init__(self, width: float, height: float, rng: np.random.Generator, owner: str = "BoxPushingConfig") -> None:
        self.width, self.height, self.rng = width, height, rng
        #: The config class named in errors (``BoxPushingV1Config`` on v1).
        self.owner = owner

    def sample(
        self, radius: float, wall_gap: float, occupied: list[tuple[float, float, float]], clearance: float, what: str
    ) -> tuple[float, float]:
        low = radius + wall_gap
        if 2 * low >= min(self.width, self.height):
            raise ConfigError(f"{self.owner}: a {what} of radius {radius:.3f} m with wall gap {wall_gap} m does not fit")
        for _ in range(5000):
            x = float(self.rng.uniform(low, self.width - low))
            y = float(self.rng.uniform(low, self.height - low))
            if self.is_free(x, y, radius, occupied, clearance):
                return x, y
        raise ConfigError(f"{self.owner}: no free spot for a {what}; the table is too crowded")

    @staticmethod
    def is_free(x: float, y: float, radius: float, occupied: list[tuple[float, float, float]], clearance: float) -> bool:
        return all(math.hypot(x - ox, y - oy) >= radius + r + clearance for ox, oy, r in occupied)
