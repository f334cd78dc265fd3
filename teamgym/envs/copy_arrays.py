"""``CopyArrays``: a task's per-episode state as arrays with a leading copy axis (one row per env copy).

A subclass declares its arrays once, in ``_allocate(k)`` (name → array of ``k`` fresh rows), and
gets their storage: :meth:`grow` and :meth:`shrink` over copies, :meth:`row` / :meth:`set_row` for
one copy's values (snapshots, regrouping a batch) and :meth:`clear_row` for a new episode. See
docs/adding_an_env.md.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CopyArrays"]


class CopyArrays:
    """Storage of the arrays that ``_allocate`` declares, for ``n_copies`` copies."""

    n_copies: int = 0

    def _allocate(self, k: int) -> dict[str, np.ndarray]:
        """``k`` fresh rows of every array, by name (what a copy holds at the start of an episode)."""
        raise NotImplementedError

    def arrays(self) -> list[str]:
        """The names of the arrays (each with the leading copy axis)."""
        return list(self._allocate(0))

    def grow(self, n_copies: int) -> None:
        """Make room for ``n_copies`` copies (existing copies keep their rows; views of them stay valid only without growth)."""
        extra = n_copies - self.n_copies
        if extra <= 0:
            return
        for name, block in self._allocate(extra).items():
            old = getattr(self, name, None)
            setattr(self, name, block if old is None else np.concatenate([old, block]))
        self.n_copies = n_copies

    def shrink(self, n_copies: int) -> None:
        """Keep only the first ``n_copies`` copies."""
        if n_copies >= self.n_copies:
            return
        for name in self.arrays():
            setattr(self, name, getattr(self, name)[:n_copies].copy())
        self.n_copies = n_copies

    def row(self, k: int) -> dict[str, np.ndarray]:
        """Copy ``k``'s values of every array (copies), as :meth:`set_row` takes them."""
        return {name: getattr(self, name)[k].copy() for name in self.arrays()}

    def set_row(self, k: int, values: dict[str, np.ndarray]) -> None:
        """Write ``values`` (from :meth:`row`, or some of its arrays) into copy ``k``."""
        for name, value in values.items():
            getattr(self, name)[k] = value

    def clear_row(self, k: int) -> None:
        """Copy ``k``'s every array back at its fresh value (a new episode starts from here)."""
        for name, value in self._allocate(1).items():
            getattr(self, name)[k] = value[0]
