"""Base class of everything that lives in a :class:`~teamgym.sim.world.World`."""

from __future__ import annotations

import pymunk

from teamgym.sim.categories import SOLID, Category


class Entity:
    """A named thing in the world made of pymunk bodies, shapes and constraints.

    Subclasses fill ``bodies``, ``shapes`` and ``constraints``; :meth:`attach` adds them
    to a space. Every shape gets ``shape.entity = self`` so that queries and contact
    callbacks can find their owner, the entity's category as filter category, and
    ``Category`` index as collision type.
    """

    kind: Category = Category.WALL

    def __init__(self, name: str) -> None:
        if not isinstance(name, str) or not name:
            raise ValueError(f"entity name must be a non-empty string, got {name!r}")
        self.name = name
        self.bodies: list[pymunk.Body] = []
        self.shapes: list[pymunk.Shape] = []
        self.constraints: list[pymunk.Constraint] = []
        self.space: pymunk.Space | None = None

    def _own(self, shape: pymunk.Shape, group: int = 0, mask: int = SOLID) -> pymunk.Shape:
        shape.entity = self
        shape.collision_type = int(self.kind)
        shape.filter = pymunk.ShapeFilter(group=group, categories=self.kind.bit, mask=mask)
        self.shapes.append(shape)
        return shape

    def attach(self, space: pymunk.Space) -> None:
        space.add(*self.bodies, *self.shapes, *self.constraints)
        self.space = space

    def detach(self, space: pymunk.Space) -> None:
        space.remove(*self.constraints, *self.shapes, *self.bodies)
        self.space = None

    @property
    def position(self) -> tuple[float, float]:
        """Centre of the entity's main body (metres)."""
        x, y = self.bodies[0].position if self.bodies else self.shapes[0].body.position
        return (x, y)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"
