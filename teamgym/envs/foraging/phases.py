"""Foraging's control-step phases over copies whose episode state shares one :class:`ForagingArrays`.

A lone :class:`~teamgym.envs.foraging.env.Foraging` env runs them over its own row; a
:class:`~teamgym.envs.batch.TeamBatch` of Foraging copies binds every copy to one row of a
shared ``ForagingArrays`` (:meth:`ForagingPhases.regroup`), so the batch's episode state is
one set of arrays over copies (a copy's state is a row: pickles and copies take it as a whole).
The phases then run copy after copy, as :class:`~teamgym.envs.step_loop.CopyPhases` does:
with two or three robots a copy's per-robot work is a few scalar operations (the go-to
controller, odometry, sightings), cheaper one copy at a time than as numpy passes over the group.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from teamgym.envs.foraging.state import ForagingArrays
from teamgym.envs.step_loop import CopyPhases

if TYPE_CHECKING:
    from teamgym.envs.foraging.env import Foraging

__all__ = ["ForagingPhases"]


class ForagingPhases(CopyPhases):
    """The phases of :class:`~teamgym.envs.step_loop.CopyPhases` for Foraging copies, bound to one ``ForagingArrays``."""

    copies: list[Foraging]
    reuse_states = True  # nothing moves a copy's bodies between its steps: its last read is the next start

    def __init__(self, copies: list[Foraging]) -> None:
        super().__init__(copies)
        self._shared: ForagingArrays | None = None  # a batch's (made by regroup)

    def regroup(self) -> None:
        """Bind copy ``k`` to row ``k`` of one shared ``ForagingArrays`` (its row so far is copied in).

        Growing or shrinking the shared arrays replaces them, so every copy's row views are bound again.
        """
        copies = self.copies
        if self._shared is None:
            own = copies[0]._arrays
            self._shared = ForagingArrays(own.n_robots, own.n_targets, own.n_slots, n_copies=0)
        self._bind_to_shared_rows(self._shared)
        for k, env in enumerate(copies):
            env._use_rows(self._shared, k)
