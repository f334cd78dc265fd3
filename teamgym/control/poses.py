"""Robot poses as Python floats for the per-control-step code of the controllers and envs.

A controller reads a robot's ``(x, y, θ)`` several times per control step (its command, the
env's arrival and progress checks); indexing ``world.robot_states`` and converting each time
costs more than the arithmetic that follows. :class:`PoseRows` converts the array once: the
world makes a new ``robot_states`` array at every read of its bodies, so the conversion is
kept until the array it came from is replaced. The values are the array's own, bit for bit.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PoseRows"]


class PoseRows:
    """``(x, y, θ)`` of every row of a state array (e.g. ``world.robot_states``), as tuples of floats."""

    def __init__(self) -> None:
        self._source: np.ndarray | None = None
        self._rows: list[tuple[float, float, float]] = []

    def __call__(self, states: np.ndarray) -> list[tuple[float, float, float]]:
        """The rows of ``states[:, :3]``, converted once per array object (do not write into ``states``)."""
        if states is not self._source:
            self._source, self._rows = states, [tuple(row) for row in states[:, :3].tolist()]
        return self._rows
