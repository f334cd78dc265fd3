"""The coarse world-model grid of paper 002 (section 4.3): cells of ``cell_size`` over the field.

Cells are indexed ``(gx, gy)`` from the field's corner at the origin (x to the right, y up);
the flat index used by the go-to-cell action is ``gy * nx + gx``. A position is quantised to
the cell that contains it (positions on or outside the field edge go to the nearest edge cell).
With the defaults (3.0 m × 2.4 m, 0.2 m cells) the grid is 15 × 12 = 180 cells, the paper's
"about 180 cells".
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GridSpec"]


@dataclass(frozen=True)
class GridSpec:
    """Geometry of the grid: field size (m) and cell size (m)."""

    width: float
    height: float
    cell_size: float

    @property
    def nx(self) -> int:
        return max(1, math.ceil(self.width / self.cell_size - 1e-9))

    @property
    def ny(self) -> int:
        return max(1, math.ceil(self.height / self.cell_size - 1e-9))

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``: the shape of a grid array (rows are y)."""
        return self.ny, self.nx

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny

    @property
    def location_bytes(self) -> int:
        """Bytes that encode one cell index (1 for up to 256 cells, the paper's "one byte")."""
        return max(1, math.ceil(math.log2(max(2, self.n_cells)) / 8))

    def cell_of(self, xy: np.ndarray) -> np.ndarray:
        """Integer ``(gx, gy)`` of the cells containing the points ``xy`` (..., 2)."""
        xy = np.asarray(xy, dtype=float)
        g = np.floor(xy / self.cell_size + 1e-9).astype(np.int64)  # 1.2 / 0.2 is cell 6, not 5.999...
        return np.minimum(np.maximum(g, 0), self._top)

    @functools.cached_property
    def _top(self) -> np.ndarray:
        return np.array([self.nx - 1, self.ny - 1])

    def centre_of(self, cells: np.ndarray) -> np.ndarray:
        """Centres (m) of the cells ``(gx, gy)`` (..., 2); centres of edge cells stay inside the field."""
        cells = np.asarray(cells, dtype=float)
        centre = (cells + 0.5) * self.cell_size
        centre[..., 0] = np.minimum(centre[..., 0], 0.5 * (cells[..., 0] * self.cell_size + self.width))
        centre[..., 1] = np.minimum(centre[..., 1], 0.5 * (cells[..., 1] * self.cell_size + self.height))
        return centre

    def index_of(self, cells: np.ndarray) -> np.ndarray:
        """Flat indices ``gy * nx + gx`` of cells ``(gx, gy)``."""
        cells = np.asarray(cells, dtype=np.int64)
        return cells[..., 1] * self.nx + cells[..., 0]

    def cell_at(self, index: int | np.ndarray) -> np.ndarray:
        """``(gx, gy)`` of flat index ``index``."""
        index = np.asarray(index, dtype=np.int64)
        return np.stack([index % self.nx, index // self.nx], axis=-1)

    def centres(self) -> np.ndarray:
        """Centres of every cell as an ``(ny, nx, 2)`` array."""
        gy, gx = np.mgrid[0 : self.ny, 0 : self.nx]
        return self.centre_of(np.stack([gx, gy], axis=-1))

    def sector_mask(self, x: float, y: float, theta: float, radius: float, fov: float) -> np.ndarray:
        """Cells (``(ny, nx)`` bool) whose centres lie in the viewing sector of a camera at ``(x, y, θ)``.

        The sector has range ``radius`` (m) and full opening ``fov`` (rad); the camera's own cell
        counts as seen. Occlusion is not modelled here (the grid is a world-model estimate).
        """
        centres = self.centres()
        dx, dy = centres[..., 0] - x, centres[..., 1] - y
        distance = np.hypot(dx, dy)
        bearing = np.abs((np.arctan2(dy, dx) - theta + math.pi) % (2 * math.pi) - math.pi)
        seen = (distance <= radius) & (bearing <= 0.5 * fov)
        gx, gy = self.cell_of(np.array([x, y]))
        seen[gy, gx] = True
        return seen
