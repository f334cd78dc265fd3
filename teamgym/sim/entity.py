"""Base class of everything that lives in a :class:`~teamgym.sim.world.World`.

An entity describes itself to the world and the renderer, so neither keeps a list of
entity types:

* ``kind`` (a :class:`Category`): collision category; the world lists robots, moving
  obstacles and boxes by it (``world.robots``, ``world.movers``, ``world.boxes``).
* ``has_state_row``: the world reads ``state_body``'s ``(x, y, angle, vx, vy, ω)`` in its
  batched state read and calls the step hooks :meth:`before_step`, :meth:`mid_step` and
  :meth:`after_step` with it.
* ``tracked``: whether the entity's path is worth recording (``world.tracked()``).
* ``fixed``: the entity never changes once added (walls, furniture): snapshots of the world
  refer to it rather than pickle it again (:meth:`~teamgym.sim.world.World.fixed_objects`).
* ``draw_layer`` and :meth:`draw`: how the renderer shows it.
* :meth:`step_group`: the object that runs the step hooks of a run of entities of one class
  (default :class:`StepGroup`, entity by entity); a class may run its hooks in one pass.

The world reads ``kind``, ``has_state_row`` and ``tracked`` when the entity is added.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pymunk

from teamgym.sim.canvas import Canvas, Layer
from teamgym.sim.categories import SOLID, Category

if TYPE_CHECKING:
    from teamgym.sim.world import World


class Entity:
    """A named thing in the world made of pymunk bodies, shapes and constraints.

    Subclasses fill ``bodies``, ``shapes`` and ``constraints``; :meth:`attach` adds them
    to a space. Every shape gets ``shape.entity = self`` so that queries and contact
    callbacks can find their owner, the entity's category as filter category, and
    ``Category`` index as collision type.
    """

    kind: Category = Category.WALL
    draw_layer: int = Layer.STATIC
    tracked: bool = False
    has_state_row: bool = False
    fixed: bool = False

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

    # -- drawing ------------------------------------------------------------------------
    def draw(self, canvas: Canvas) -> None:
        """Draw the entity on ``canvas`` (default: nothing)."""

    # -- control-step hooks (called only when ``has_state_row``) ------------------------
    @property
    def state_body(self) -> pymunk.Body:
        """The body whose state row the world reads (default: the first body)."""
        return self.bodies[0]

    def before_step(self, world: World, state: list[float]) -> float | None:
        """Prepare a control step from ``state`` = ``(x, y, angle, vx, vy, ω)`` of ``state_body``.

        Return a time in ``(0, world.dt)`` at which the world must call :meth:`mid_step`
        (it splits the step there), or ``None``.
        """
        return None

    def mid_step(self) -> None:
        """Called at the time :meth:`before_step` asked for."""

    def after_step(self, world: World, start: list[float], end: list[float]) -> None:
        """Finish a control step; ``start`` and ``end`` are the state rows before and after."""

    @classmethod
    def step_group(cls, entities: list[Entity], world: World) -> StepGroup:
        """The runner of the step hooks of ``entities`` (all of this class, consecutive state rows of ``world``)."""
        return StepGroup(entities)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class StepGroup:
    """Runs the step hooks of a run of entities of one class, entity by entity, in state-row order.

    The :class:`~teamgym.sim.world.World` calls :meth:`before` with the entities' state rows
    (lists, and the same rows as an array), then integrates, then :meth:`after`. ``direct``:
    the hooks set bodies through pymunk (rather than into the world's body buffer, see
    :meth:`~teamgym.sim.world.World.body_buffer`).
    """

    direct = True

    def __init__(self, entities: list[Entity]) -> None:
        self.entities = entities

    def before(self, world: World, rows: list[list[float]], block: np.ndarray) -> list[tuple[float, Entity]]:
        """Every entity's :meth:`Entity.before_step`; returns the ``(time, entity)`` pairs that asked for a mid-step call."""
        switches = []
        for entity, row in zip(self.entities, rows):
            at = entity.before_step(world, row)
            if at is not None:
                switches.append((at, entity))
        return switches

    def after(self, world: World, starts: list[list[float]], ends: list[list[float]]) -> None:
        """Every entity's :meth:`Entity.after_step`."""
        for entity, start, end in zip(self.entities, starts, ends):
            entity.after_step(world, start, end)


class PointEntity(Entity):
    """An entity at a point, without bodies or shapes: it collides with nothing."""

    def __init__(self, name: str, position: tuple[float, float]) -> None:
        super().__init__(name)
        self.position = position

    @property
    def position(self) -> tuple[float, float]:
        return self._position

    @position.setter
    def position(self, value: tuple[float, float]) -> None:
        self._position = (float(value[0]), float(value[1]))
