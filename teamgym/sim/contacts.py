"""Contacts between entities and their per-entity counts.

What is counted
---------------
Chipmunk calls the world's ``begin`` callback once when two shapes start touching (in any
physics substep). Each such call between two entities is one :class:`Contact` and counts
one for each side: a robot that hits a wall and, in the same control step, another robot
gets 2 and each of the others 1. A pair that touches, separates and touches again within a
step begins twice; a pair that stays in touch over several steps counts only in the step it
began. Both sides being the same entity (two of its shapes) counts twice for it. Counts are
kept per entity name: ``new`` for the last control step, ``total`` since the world was
built (an entity removed and added again under the same name keeps its total).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pymunk

from teamgym.sim.categories import Category


@dataclass(frozen=True)
class Contact:
    """A contact that began during the last control step, between two entities."""

    a: str
    b: str
    kind_a: Category
    kind_b: Category


class ContactCounter:
    """Records the contacts of the current control step and counts them per entity name."""

    def __init__(self) -> None:
        #: Contacts that began during the last control step, in order.
        self.last_step: list[Contact] = []
        #: Contacts per name that began during the last control step.
        self.new: dict[str, int] = {}
        #: Contacts per name since the counter was made.
        self.total: dict[str, int] = {}

    def new_step(self) -> None:
        """Forget the last step's contacts (the totals stay)."""
        self.last_step = []
        self.new = {}

    def record(self, contact: Contact) -> None:
        self.last_step.append(contact)
        new, total = self.new, self.total
        for name in (contact.a, contact.b):
            new[name] = new.get(name, 0) + 1
            total[name] = total.get(name, 0) + 1


class PenetrationProbe:
    """Records the deepest overlap (m) of every touching pair involving ``kind``, in every physics substep.

    Installs a ``post_solve`` collision callback on ``space``, which Chipmunk calls in each
    substep for every touching pair (however the world drives its substeps), so it sees the
    worst overlap rather than only the state at the end of a control step. For physics tests
    and benchmarks; envs do not install it.
    """

    def __init__(self, space: pymunk.Space, kind: Category = Category.ROBOT) -> None:
        self.worst: dict[frozenset, float] = {}
        self.calls = 0
        space.on_collision(int(kind), post_solve=self._post_solve)

    def _post_solve(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: Any) -> None:
        self.calls += 1
        key = frozenset(getattr(getattr(s, "entity", None), "kind", None) for s in arbiter.shapes)
        depth = max((-p.distance for p in arbiter.contact_point_set.points), default=0.0)
        self.worst[key] = max(self.worst.get(key, -float("inf")), depth)

    def deepest(self, kind_a: Category, kind_b: Category) -> float:
        """The deepest overlap seen between kinds ``kind_a`` and ``kind_b`` (0 if they never touched)."""
        return self.worst.get(frozenset((kind_a, kind_b)), 0.0)
