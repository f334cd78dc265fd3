"""The MAPS potential fields of DMAPS (paper 002, section 3.1 and Figs. 4–5).

MAPS "constructs a virtual map of the physical environment using potential fields ...
components are represented by regions of attraction or repulsion"; the go-to cell is "the
darkest cell in the map" (section 4.3). Here a field is a fitness grid ``(ny, nx)`` (higher
is more attractive) and :meth:`PotentialField.best` returns the fittest admissible cell.

* **Approach** (a robot with an assigned target): attraction peaked at the target's cell,
  ``−distance(cell, target)`` (m), so the target's cell wins whenever it is admissible, and
  otherwise the admissible cell closest to it.
* **Search** (no assigned target), a sum of components:

  - novelty ``1 − exp(−age / novelty_time)``, ``age`` = time since anyone last saw the cell
    (``last_seen`` of the world model; never seen: 1): attraction to cells not seen recently;
  - ``− distance_cost · distance(cell, robot)`` (m): a mild preference for near cells;
  - ``− turn_cost · (1 − cos bearing) / 2``: a slight preference for cells ahead (less turning);
  - ``− teammate_repulsion · Σ_j exp(−d_j² / (2 teammate_spread²))`` around every other robot:
    pushes searchers apart so they cover different parts of the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from teamgym.envs.foraging.grid import GridSpec

__all__ = ["FieldParams", "PotentialField"]


@dataclass(frozen=True)
class FieldParams:
    """Weights of the search field (see the module docstring)."""

    novelty_time: float = 30.0
    distance_cost: float = 0.15
    turn_cost: float = 0.1
    teammate_repulsion: float = 0.6
    teammate_spread: float = 0.5


class PotentialField:
    """Approach and search fields on a grid (precomputed cell centres)."""

    def __init__(self, grid: GridSpec, params: FieldParams | None = None) -> None:
        self.grid = grid
        self.params = params or FieldParams()
        centres = grid.centres()
        self.cx = np.ascontiguousarray(centres[..., 0])
        self.cy = np.ascontiguousarray(centres[..., 1])

    def distance_from(self, x: float, y: float) -> np.ndarray:
        """Distance (m) of every cell centre from ``(x, y)`` ``(ny, nx)``."""
        return np.hypot(self.cx - x, self.cy - y)

    def approach(self, target_cell: tuple[int, int] | np.ndarray) -> np.ndarray:
        """Fitness peaked at the target's cell: minus the distance (m) to its centre."""
        tx, ty = self.grid.centre_of(np.asarray(target_cell, dtype=float))
        return -self.distance_from(float(tx), float(ty))

    def search(self, now: float, last_seen: np.ndarray, pose: np.ndarray, others: np.ndarray | None = None) -> np.ndarray:
        """Search fitness for a robot at ``pose`` (x, y, θ) given ``last_seen`` (s) and other robots' positions ``(k, 2)``."""
        p = self.params
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        dx, dy = self.cx - x, self.cy - y
        distance = np.hypot(dx, dy)
        fitness = -np.expm1(-(now - last_seen) / p.novelty_time)  # 1 − exp(−age/τ); never seen (−inf): 1
        fitness -= p.distance_cost * distance
        if p.turn_cost:
            ahead = (dx * math.cos(theta) + dy * math.sin(theta)) / np.maximum(distance, 1e-9)
            fitness -= 0.5 * p.turn_cost * (1.0 - ahead)
        if others is not None and len(others) and p.teammate_repulsion:
            others = np.asarray(others, dtype=float).reshape(-1, 2)
            d2 = (self.cx[None] - others[:, 0, None, None]) ** 2 + (self.cy[None] - others[:, 1, None, None]) ** 2
            fitness -= p.teammate_repulsion * np.exp(-d2 / (2.0 * p.teammate_spread**2)).sum(axis=0)
        return fitness

    @staticmethod
    def best(fitness: np.ndarray, mask: np.ndarray | None = None) -> int:
        """Flat index ``gy · nx + gx`` of the fittest admissible cell (``mask``: flat, 1 = admissible; first on ties)."""
        flat = fitness.ravel()
        if mask is not None:
            mask = np.asarray(mask).ravel()
            if not mask.any():
                return int(np.argmax(flat))
            flat = np.where(mask > 0, flat, -np.inf)
        return int(np.argmax(flat))
