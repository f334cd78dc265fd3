"""Static scenes carried over from one episode's world to the next.

An env whose map does not change between episodes (Rendezvous-v0's corridor walls,
Exploration-v0's office) builds its walls, doors and furniture once and :meth:`places
<StaticScene.place>` the same entities in each new :class:`~teamgym.sim.world.World`,
instead of building hundreds of pymunk bodies and shapes every reset.

The new world is the same as one built from scratch: a fresh pymunk space whose state is
determined by what was added to it, with which properties, in which order. Chipmunk numbers
shapes in the order they are added, and its spatial index and the order of contacts (hence
the last bits of a rollout) follow from that, so an env must place its scene at the point
of its build where it used to add those entities. A scene entity is taken out of the
previous world when it is placed in the next one (the previous world keeps its other
entities); its own state (a door's open or closed) is whatever it was last set to.
"""

from __future__ import annotations

from collections.abc import Iterable

import pymunk

from teamgym.sim.entity import Entity
from teamgym.sim.world import World

__all__ = ["StaticScene"]


class StaticScene:
    """Entities with only static bodies, placed in one world at a time, in the order given."""

    def __init__(self, entities: Iterable[Entity]) -> None:
        self.entities: list[Entity] = list(entities)
        names = [e.name for e in self.entities]
        if len(set(names)) != len(names):
            raise ValueError(f"StaticScene: entity names repeat: {sorted(n for n in set(names) if names.count(n) > 1)}")
        moving = [e.name for e in self.entities if e.has_state_row or any(b.body_type != pymunk.Body.STATIC for b in e.bodies)]
        if moving:
            raise ValueError(f"StaticScene: entities must have static bodies only, got moving ones: {moving}")
        #: The world the scene was last placed in (``None`` before the first placement and after :meth:`release`).
        self.world: World | None = None

    def place(self, world: World) -> None:
        """Add the scene's entities to ``world`` in their order, taking them out of the world they were in.

        Raises ``ValueError`` (and changes nothing) if ``world`` already has an entity of one of their names.
        """
        taken = [e.name for e in self.entities if e.name in world.entities]
        if taken:
            raise ValueError(f"StaticScene.place: the world already has entities named {taken}")
        self.release()
        for entity in self.entities:
            world.add(entity)
        self.world = world

    def release(self) -> None:
        """Take the entities out of the world they were placed in; its other entities stay."""
        if self.world is not None:
            self.world.remove_many([e.name for e in self.entities if self.world.entities.get(e.name) is e])
            self.world = None
