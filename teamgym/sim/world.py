"""The simulated world: one ``pymunk.Space`` stepped in fixed control steps.

Units are SI (metres, seconds, radians, kilograms, newtons). Gravity is zero: the space
is a top-down view of a table or floor; ground friction is modelled per body by joints
to the static body (pymunk's top-down friction technique), see :mod:`teamgym.sim.robot`
and :class:`teamgym.sim.objects.Box`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymunk

from teamgym.sim.categories import Category
from teamgym.sim.chipmunk import BodyReader, space_step
from teamgym.sim.entity import Entity
from teamgym.sim.objects import Box, MovingPolygon, Wall
from teamgym.sim.robot import DiffDriveRobot


@dataclass(frozen=True)
class Contact:
    """A contact that began during the last control step, between two entities."""

    a: str
    b: str
    kind_a: Category
    kind_b: Category


class World:
    """Owns the pymunk space, the entities in it and the control-step clock.

    Parameters
    ----------
    size:
        ``(width, height)`` of the arena in metres; the arena spans ``[0, w] x [0, h]``.
    dt:
        Control step Δt in seconds (0.1 s in papers 001 and 004).
    substeps:
        Physics substeps per control step (fixed, so runs are deterministic).
    collision_slop:
        Allowed penetration in metres. pymunk's default (0.1) assumes pixels; in metres we
        allow 0.2 mm.
    """

    def __init__(
        self,
        size: tuple[float, float],
        dt: float = 0.1,
        substeps: int = 20,
        collision_slop: float = 2e-4,
        iterations: int = 10,
    ) -> None:
        if dt <= 0 or substeps < 1:
            raise ValueError(f"World needs dt > 0 and substeps >= 1, got dt={dt}, substeps={substeps}")
        self.size = (float(size[0]), float(size[1]))
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)
        self.space.collision_slop = collision_slop
        self.space.iterations = iterations
        self.time = 0.0
        self.entities: dict[str, Entity] = {}
        self.contacts: list[Contact] = []
        self.space.on_collision(begin=self._on_contact_begin)
        self.robots: list[DiffDriveRobot] = []
        self.movers: list[MovingPolygon] = []
        self.boxes: list[Box] = []
        self._reader: BodyReader | None = None
        #: ``(x, y, angle, vx, vy, ω)`` of every robot / moving obstacle after the last step.
        self.robot_states = np.zeros((0, 6))
        self.mover_states = np.zeros((0, 6))

    # -- entities -------------------------------------------------------------------
    def add(self, entity: Entity) -> Entity:
        """Add an entity (robot, wall, box, ...) to the world under its unique name."""
        if entity.name in self.entities:
            raise ValueError(f"an entity named {entity.name!r} is already in the world")
        entity.attach(self.space)
        self.entities[entity.name] = entity
        if isinstance(entity, DiffDriveRobot):
            self.robots.append(entity)
        elif isinstance(entity, MovingPolygon):
            self.movers.append(entity)
        elif isinstance(entity, Box):
            self.boxes.append(entity)
        self._reader = None
        return entity

    def add_boundary(self, thickness: float = 0.02) -> list[Wall]:
        """Enclose the arena ``[0, w] x [0, h]`` by four walls lying just outside it."""
        w, h = self.size
        t = thickness / 2
        corners = [(-t, -t), (w + t, -t), (w + t, h + t), (-t, h + t)]
        walls = []
        for i, name in enumerate(("wall_south", "wall_east", "wall_north", "wall_west")):
            walls.append(self.add(Wall(name, corners[i], corners[(i + 1) % 4], thickness)))
        return walls

    def remove(self, name: str) -> Entity:
        """Remove the entity called ``name`` from the world and return it."""
        try:
            entity = self.entities.pop(name)
        except KeyError:
            raise KeyError(f"no entity named {name!r} in the world") from None
        entity.detach(self.space)
        if entity in self.robots:
            self.robots.remove(entity)
        if entity in self.movers:
            self.movers.remove(entity)
        if entity in self.boxes:
            self.boxes.remove(entity)
        self._reader = None
        return entity

    def of_kind(self, kind: Category) -> list[Entity]:
        return [e for e in self.entities.values() if e.kind == kind]

    def __getitem__(self, name: str) -> Entity:
        try:
            return self.entities[name]
        except KeyError:
            raise KeyError(f"no entity named {name!r} in the world") from None

    # -- stepping -------------------------------------------------------------------
    def step(self) -> None:
        """Advance one control step Δt.

        Moving obstacles plan their bounce, then every robot starts its command. A robot
        with ``actuation_delay`` d > 0 keeps its previous command for the first d seconds
        of the step and switches at d (the delay T0 of paper 001, section 6.1); the step is
        split at every such switching time. Each part is integrated with substeps no
        longer than Δt / ``substeps``.
        """
        dt = self.dt
        self.contacts = []
        before, movers = self.read_states()
        if self.movers:
            bounds = (0.0, 0.0, self.size[0], self.size[1])
            for mover, state in zip(self.movers, movers.tolist()):
                mover.plan_bounce(bounds, dt, state)
        switches: dict[float, list[DiffDriveRobot]] = {}
        for robot, row in zip(self.robots, before.tolist()):
            robot.begin_step(row)
            delay = robot.actuation_delay
            if 0.0 < delay < dt and robot.applied_command != robot.command:
                switches.setdefault(delay, []).append(robot)
        h = dt / self.substeps
        if not switches:
            self._integrate(h, self.substeps)
        else:
            elapsed = 0.0
            for boundary in [*sorted(switches), dt]:
                duration = boundary - elapsed
                n = max(1, int(np.ceil(duration / h - 1e-9)))
                self._integrate(duration / n, n)
                elapsed = boundary
                for robot in switches.get(boundary, ()):
                    robot.apply_command(robot.command)
        after = self.read_states()[0]
        for robot, start, end in zip(self.robots, before.tolist(), after.tolist()):
            robot.end_step(dt, start, end)
        self.time += dt

    def read_states(self) -> tuple[np.ndarray, np.ndarray]:
        """Refresh and return ``(robot_states, mover_states)``, rows ``(x, y, angle, vx, vy, ω)``."""
        if self._reader is None:
            self._reader = BodyReader([r.body for r in self.robots] + [m.body for m in self.movers])
        states = self._reader.read(self.space) if self._reader.bodies else np.zeros((0, 6))
        n = len(self.robots)
        self.robot_states, self.mover_states = states[:n], states[n:]
        return self.robot_states, self.mover_states

    def _integrate(self, h: float, n: int) -> None:
        """``n`` physics steps of length ``h``.

        The first goes through ``pymunk.Space.step`` (which also runs pymunk's deferred
        additions, removals and post-step callbacks); the rest call Chipmunk's step
        directly, skipping about 3 µs of Python bookkeeping per substep. That is safe
        because nothing adds or removes objects during a control step (the contact
        callback only records).
        """
        self.space.step(h)
        if n > 1:
            raw_step, handle = space_step, self.space._space
            for _ in range(n - 1):
                raw_step(handle, h)

    def _on_contact_begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        sa, sb = arbiter.shapes
        ea = getattr(sa, "entity", None)
        eb = getattr(sb, "entity", None)
        if ea is not None and eb is not None:
            self.contacts.append(Contact(ea.name, eb.name, ea.kind, eb.kind))

    # -- queries --------------------------------------------------------------------
    def contacts_of(self, name: str) -> list[Contact]:
        """Contacts of entity ``name`` that began in the last control step."""
        return [c for c in self.contacts if c.a == name or c.b == name]
