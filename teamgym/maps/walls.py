"""Many walls as one fixed entity: their segment shapes on one static body.

A map's walls do not move and do not change, so they need not be entities (and pymunk
bodies) of their own. :class:`JoinedWalls` takes the shapes of a list of
:class:`~teamgym.sim.objects.Wall` entities, in their order, onto one static body at the
origin, like the walls' own bodies. The world is the same as with the walls added one by
one: the same shapes (geometry, radius, friction, filter, collision type) enter the space in
the same order, so Chipmunk numbers them alike, and a static body at the origin stands still
whichever shape it carries. What is saved is the bookkeeping: one entity to place and take
out instead of hundreds, and one body instead of hundreds in every batch read of the
world's bodies (two per control step; :class:`~teamgym.sim.chipmunk.BodyReader` reads every
body of the space).

Contacts and queries name the joined entity (``name``), not the single walls. The walls
given up stay as plain geometry (``walls``: their ``a``, ``b``, ``thickness``), drawn in
their order, without bodies or shapes.
"""

from __future__ import annotations

from collections.abc import Sequence

import pymunk

from teamgym.sim.canvas import Canvas
from teamgym.sim.categories import Category
from teamgym.sim.entity import Entity
from teamgym.sim.objects import Door, Wall

__all__ = ["JoinedWalls"]


class JoinedWalls(Entity):
    """The walls ``walls`` (fresh :class:`~teamgym.sim.objects.Wall` entities, no doors) as one static entity."""

    kind = Category.WALL
    fixed = True

    def __init__(self, name: str, walls: Sequence[Wall]) -> None:
        super().__init__(name)
        self.walls = list(walls)
        if not self.walls:
            raise ValueError(f"{name}: JoinedWalls needs at least one wall")
        wrong = [w for w in self.walls if not isinstance(w, Wall) or isinstance(w, Door)]
        if wrong:
            raise TypeError(f"{name}: JoinedWalls takes Wall entities (not doors), got {wrong[0]!r}")
        taken = [w.name for w in self.walls if w.space is not None or len(w.shapes) != 1]
        if taken:
            raise ValueError(f"{name}: walls already in a space or joined: {taken}")
        self.body = pymunk.Body(body_type=pymunk.Body.STATIC)
        for wall in self.walls:
            shape = wall.shapes[0]
            shape.body = self.body
            shape.entity = self
            self.shapes.append(shape)
            wall.body, wall.bodies, wall.shapes = self.body, [], []
        self.bodies = [self.body]

    @property
    def position(self) -> tuple[float, float]:
        """Centre of the walls' bounding box."""
        xs = [x for w in self.walls for x in (w.a[0], w.b[0])]
        ys = [y for w in self.walls for y in (w.a[1], w.b[1])]
        return ((min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2)

    def draw(self, canvas: Canvas) -> None:
        for wall in self.walls:
            wall.draw(canvas)
