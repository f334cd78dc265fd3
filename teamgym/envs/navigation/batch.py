"""``NavigationBatch``: the name earlier releases gave a batch of Navigation-v0 copies.

Every env now has a batch form, :class:`~teamgym.envs.batch.TeamBatch` (``teamgym.make_batch``);
this name stays for code written against it and builds exactly that.
"""

from __future__ import annotations

from typing import Any

from teamgym.envs.batch import TeamBatch
from teamgym.envs.navigation.env import Navigation

__all__ = ["NavigationBatch"]


class NavigationBatch(TeamBatch):
    """``TeamBatch(Navigation, n_copies, config)``: ``n_copies`` Navigation-v0 copies with one config."""

    def __init__(self, n_copies: int, **config: Any) -> None:
        super().__init__(Navigation, n_copies, config)
