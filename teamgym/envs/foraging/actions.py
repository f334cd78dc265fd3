"""``goto_cell``: the go-to-cell action of ``Foraging-v0`` (DMAPS's output, paper 002 section 4.3)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from teamgym.envs.actions import ActionType
from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.spaces import MaskedDiscrete

if TYPE_CHECKING:
    from teamgym.envs.foraging.env import Foraging

__all__ = ["GoToCellAction"]


class GoToCellAction(ActionType):
    """``Discrete(nx · ny)``: the flat index ``gy · nx + gx`` of the cell to drive to.

    The env's :class:`~teamgym.envs.foraging.controller.GoToController` turns every robot's
    cell into ``(v, ω)`` once per step (:meth:`start`). Cells whose centre lies closer to a
    wall than the robot's radius plus 1 cm cannot be reached and are masked (none on the
    default field; an edge strip narrower than a cell has such cells).
    """

    name = "goto_cell"
    has_masks = True

    def __init__(self, grid: GridSpec, robot_radius: float) -> None:
        self.grid = grid
        centres = grid.centres().reshape(-1, 2)
        clearance = np.minimum.reduce([centres[:, 0], grid.width - centres[:, 0], centres[:, 1], grid.height - centres[:, 1]])
        self.admissible = (clearance >= robot_radius + 0.01 - 1e-9).astype(np.int8)
        self._cells: dict[str, Any] = {}
        self._commands: dict[str, tuple[float, float]] | None = None

    def space(self) -> MaskedDiscrete:
        return MaskedDiscrete(self.grid.n_cells)

    def start(self, env: Foraging, actions: dict[str, Any]) -> None:
        self._cells, self._commands = actions, None

    def act(self, env: Foraging, agent: str, action: Any) -> tuple[float, float]:
        """The controller's command for ``agent``; every robot's are computed at the step's first call.

        (A batch of copies computes them for all its copies at once and never calls this.)
        """
        if self._commands is None:
            self._commands = env.goto_commands({name: int(cell) for name, cell in self._cells.items()})
        return self._commands[agent]

    def mask(self, env: Foraging, agent: str) -> np.ndarray:
        return self.admissible.copy()

    def describe(self, action: Any) -> str:
        gx, gy = (int(v) for v in self.grid.cell_at(int(action)))
        return f"cell {int(action)} (gx={gx}, gy={gy})"
