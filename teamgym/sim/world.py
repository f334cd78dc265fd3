"""The simulated world: one ``pymunk.Space`` stepped in fixed control steps.

Units are SI (metres, seconds, radians, kilograms, newtons). Gravity is zero: the space
is a top-down view of a table or floor; ground friction is modelled per body by joints
to the static body (pymunk's top-down friction technique), see :mod:`teamgym.sim.robot`
and :class:`teamgym.sim.objects.Box`.

The world keeps no list of entity types: it groups entities by what they declare
(``kind``, ``has_state_row``, ``tracked``; see :mod:`teamgym.sim.entity`).
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Iterable, Sequence

import numpy as np
import pymunk

from teamgym.sim import snapshot
from teamgym.sim.categories import Category
from teamgym.sim.chipmunk import BodyReader, can_collide, shape_bbs, space_step
from teamgym.sim.contacts import Contact, ContactCounter
from teamgym.sim.entity import Entity, StepGroup
from teamgym.sim.objects import Wall
from teamgym.sim.solver_state import SolverSpace

__all__ = ["Contact", "World"]


def _kind_value(entity: Entity) -> int:
    return int(entity.kind)


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
    coarse_substeps, contact_reach:
        Adaptive substeps (``coarse_substeps`` = 0: off). A control step in which no contact
        can begin is integrated in ``coarse_substeps`` substeps instead of ``substeps``: every
        shape of an entity with a state row has its bounding box grown by ``contact_reach``
        (m; the distance one body can travel in Δt, with margin) and no grown box meets a
        grown box or a fixed shape it may collide with. The decision depends on the state
        only, so runs stay deterministic; steps with actuation-delay switches always use
        ``substeps``.
    collision_slop:
        Allowed penetration in metres. pymunk's default (0.1) assumes pixels; in metres we
        allow 0.2 mm.

    Entities of kind ``ROBOT``, ``OBSTACLE`` and ``BOX`` are listed, in the order they were
    added, in ``robots``, ``movers`` and ``boxes``. Entities with ``has_state_row`` are read
    in one batch before and after every step, grouped by kind (ascending ``Category``
    value), in the order added within a kind; ``states`` holds those rows, and
    ``robot_states`` / ``mover_states`` the rows of the robots / moving obstacles.
    """

    def __init__(
        self,
        size: tuple[float, float],
        dt: float = 0.1,
        substeps: int = 20,
        collision_slop: float = 2e-4,
        iterations: int = 10,
        coarse_substeps: int = 0,
        contact_reach: float = 0.0,
    ) -> None:
        if dt <= 0 or substeps < 1:
            raise ValueError(f"World needs dt > 0 and substeps >= 1, got dt={dt}, substeps={substeps}")
        if not 0 <= coarse_substeps <= substeps or contact_reach < 0:
            raise ValueError(
                f"World needs 0 <= coarse_substeps <= substeps and contact_reach >= 0, "
                f"got coarse_substeps={coarse_substeps}, contact_reach={contact_reach}"
            )
        self.size = (float(size[0]), float(size[1]))
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.coarse_substeps = int(coarse_substeps)
        self.contact_reach = float(contact_reach)
        #: Control steps integrated with ``substeps`` / ``coarse_substeps`` since the world was built.
        self.fine_steps = 0
        self.coarse_steps = 0
        #: Contacts that began during a coarse control step (the reach check should make this 0).
        self.coarse_contacts = 0
        self._coarse_now = False
        self._contact_check: tuple | None = None
        self.space = SolverSpace()
        self.space.gravity = (0.0, 0.0)
        self.space.collision_slop = collision_slop
        self.space.iterations = iterations
        self.time = 0.0
        self.entities: dict[str, Entity] = {}
        self._contacts = ContactCounter()
        self.space.on_collision(begin=self._on_contact_begin)
        self.robots: list[Entity] = []
        self.movers: list[Entity] = []
        self.boxes: list[Entity] = []
        #: Robot name -> its row in ``robot_states``.
        self.robot_rows: dict[str, int] = {}
        self._stepped: list[Entity] = []
        self._rows_of: dict[Category, slice] = {}
        self._tracked: list[Entity] = []
        self._reader: BodyReader | None = None
        #: Step groups of the state rows: ``(group, rows)`` per run of entities of one class (see ``step_group``).
        self._plan: list[tuple[StepGroup, slice]] | None = None
        #: The reader's body buffer holds the space's bodies as they are / holds writes not yet made.
        self._buffer_fresh = False
        self._buffer_dirty = False
        self._buffer_writable: bool | None = None
        #: Fixed entities with their bodies and shapes, and their snapshot (see ``fixed_objects``).
        self._fixed: tuple[list, bytes | None] | None = None
        #: ``(x, y, angle, vx, vy, ω)`` of every entity with a state row after the last step.
        self.states = np.zeros((0, 6))
        #: The rows of ``states`` that belong to robots / moving obstacles.
        self.robot_states = np.zeros((0, 6))
        self.mover_states = np.zeros((0, 6))

    # -- entities -------------------------------------------------------------------
    def add(self, entity: Entity) -> Entity:
        """Add an entity (robot, wall, box, ...) to the world under its unique name."""
        if entity.name in self.entities:
            raise ValueError(f"an entity named {entity.name!r} is already in the world")
        entity.attach(self.space)
        self.entities[entity.name] = entity
        self._group(entity)
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
        return self.remove_many([name])[0]

    def remove_many(self, names: Sequence[str]) -> list[Entity]:
        """Remove the entities ``names`` from the world and return them, in that order.

        All or nothing: an unknown (or repeated) name raises ``KeyError`` before any is removed.
        """
        missing = [name for name in names if name not in self.entities]
        if missing:
            raise KeyError(f"no entity named {missing[0]!r} in the world")
        if len(set(names)) != len(names):
            raise KeyError(f"entity names to remove repeat: {sorted(n for n in set(names) if names.count(n) > 1)}")
        removed = [self.entities.pop(name) for name in names]
        for entity in removed:
            entity.detach(self.space)
        self._regroup()
        return removed

    def _regroup(self) -> None:
        """Rebuild the lists derived from the entities' declarations (in place, so references stay valid)."""
        for listed in (self.robots, self.movers, self.boxes):
            listed.clear()
        self._tracked = []
        self.robot_rows = {}
        self._stepped = []
        self._rows_of = {}
        for entity in self.entities.values():
            self._group(entity)
        self._forget_reader()
        self._contact_check = None

    def _group(self, entity: Entity) -> None:
        """Enter ``entity``, the last one in ``entities``, in the derived lists.

        Constant time for an entity without a state row (a wall), so building a scene is
        linear in its size; an entity with a state row re-indexes the state rows.
        """
        listed = {Category.ROBOT: self.robots, Category.OBSTACLE: self.movers, Category.BOX: self.boxes}.get(entity.kind)
        if listed is not None:
            listed.append(entity)
            if entity.kind == Category.ROBOT:
                self.robot_rows[entity.name] = len(listed) - 1
        if entity.tracked:
            self._tracked.append(entity)
        if entity.has_state_row:
            # State rows are grouped by kind (ascending value), in the order added within a kind.
            self._stepped.insert(bisect_right(self._stepped, int(entity.kind), key=_kind_value), entity)
            self._rows_of = {}
            for row, stepped in enumerate(self._stepped):
                first = self._rows_of.get(stepped.kind, slice(row, row)).start
                self._rows_of[stepped.kind] = slice(first, row + 1)
        self._forget_reader()
        self._contact_check = None
        self._fixed = None

    def _forget_reader(self) -> None:
        """The bodies changed: a new reader, step groups and body buffer on the next read."""
        self._reader = None
        self._plan = None
        self._buffer_fresh = self._buffer_dirty = False
        self._buffer_writable = None

    def of_kind(self, kind: Category) -> list[Entity]:
        return [e for e in self.entities.values() if e.kind == kind]

    def tracked(self) -> list[Entity]:
        """Entities whose path is worth recording (robots, moving obstacles, boxes, ...), in the order added."""
        return list(self._tracked)

    def __getitem__(self, name: str) -> Entity:
        try:
            return self.entities[name]
        except KeyError:
            raise KeyError(f"no entity named {name!r} in the world") from None

    # -- stepping -------------------------------------------------------------------
    def step(self, reuse_states: bool = False) -> None:
        """Advance one control step Δt.

        ``reuse_states``: the caller guarantees that no body was moved since the last read (the
        end of the previous step, or ``read_states``), so ``states`` is taken as the start rows
        instead of reading the space again (a batch stepping its copies does this).

        Every entity with a state row gets :meth:`~teamgym.sim.entity.Entity.before_step`
        (moving obstacles plan their bounce, robots start their command), in state-row
        order. An entity may ask to be called back at a time within the step (a robot with
        ``actuation_delay`` d > 0 keeps its previous command for the first d seconds and
        switches at d, the delay T0 of paper 001, section 6.1); the step is split at every
        such time. Each part is integrated with substeps no longer than Δt / ``substeps``.
        Then every such entity gets ``after_step`` (robots update encoders and odometer).
        """
        dt = self.dt
        block = self.begin_step(reuse_states)
        before = block.tolist()
        switches: dict[float, list[Entity]] = {}
        for group, rows in self.step_plan():
            if group.direct:
                self._flush_buffer()
            for at, entity in group.before(self, before[rows], block[rows]):
                switches.setdefault(at, []).append(entity)
            if group.direct:
                self._buffer_fresh = False
        self._flush_buffer()
        self._buffer_fresh = False
        h = dt / self.substeps
        coarse = not switches and self.coarse_substeps > 0 and self._contact_free()
        if coarse:
            self.coarse_steps += 1
            self._coarse_now = True
            self._integrate(dt / self.coarse_substeps, self.coarse_substeps)
            self._coarse_now = False
        elif not switches:
            self.integrate_step()
        else:
            self.fine_steps += 1
            elapsed = 0.0
            for boundary in [*sorted(switches), dt]:
                duration = boundary - elapsed
                n = max(1, int(np.ceil(duration / h - 1e-9)))
                self._integrate(duration / n, n)
                elapsed = boundary
                for entity in switches.get(boundary, ()):
                    entity.mid_step()
        after = self._read().tolist()
        for group, rows in self._plan:
            group.after(self, before[rows], after[rows])
        self.time += dt

    # -- the parts of a step, for worlds stepped together (teamgym.sim.world_group) ----
    def begin_step(self, reuse_states: bool = False) -> np.ndarray:
        """Start a control step: forget the last step's contacts; the state rows at its start (see :meth:`step`)."""
        self.forget_step_contacts()
        fresh = reuse_states and self._reader is not None and len(self.states) == len(self._stepped)
        return self.states if fresh else self._read()

    def forget_step_contacts(self) -> None:
        """Start a control step's contact record (the last step's contacts are forgotten, the totals kept)."""
        self._contacts.new_step()

    def step_plan(self) -> list[tuple[StepGroup, slice]]:
        """The step groups of the state rows, each with its rows: ``(group, rows)`` per run of entities of one class."""
        return self._plan if self._plan is not None else self._make_plan()

    def write_bodies(self, rows: np.ndarray, values: np.ndarray) -> None:
        """Set the bodies at ``rows`` of :meth:`body_buffer` to ``values`` (``(x, y, angle, vx, vy, ω)`` rows) in the space."""
        self.body_buffer()[rows] = values
        self._flush_buffer()
        self._buffer_fresh = False

    def bodies_moved(self) -> None:
        """Bodies were set through pymunk directly: :meth:`body_buffer` reads the space again."""
        self._buffer_fresh = False

    def integrate_step(self) -> None:
        """Integrate one whole control step in ``substeps`` substeps (no mid-step switches)."""
        self.fine_steps += 1
        self._integrate(self.dt / self.substeps, self.substeps)

    def finish_step(self) -> np.ndarray:
        """Read the state rows at the end of a control step and advance the clock; returns the rows."""
        after = self._read()
        self.time += self.dt
        return after

    def _make_plan(self) -> list[tuple[StepGroup, slice]]:
        """Runs of consecutive state rows whose entities are of one class, each with its class's step group."""
        runs: list[list] = []
        for row, entity in enumerate(self._stepped):
            if runs and type(entity) is runs[-1][0]:
                runs[-1][1].append(entity)
            else:
                runs.append([type(entity), [entity], row])
        self._plan = [(cls.step_group(group, self), slice(start, start + len(group))) for cls, group, start in runs]
        return self._plan

    def body_rows(self, bodies: list[pymunk.Body]) -> np.ndarray | None:
        """Rows of ``bodies`` in :meth:`body_buffer`, or ``None`` when this world's buffer cannot be written.

        For step groups (:meth:`~teamgym.sim.entity.Entity.step_group`), while the plan is made.
        """
        if self._reader is None or self._reader.every.shape[0] == 0:
            self._read()
        if self._buffer_writable is None:
            self._buffer_writable = self._reader.writable(self.space)
        return self._reader.rows_of(bodies) if self._buffer_writable else None

    def body_buffer(self) -> np.ndarray:
        """Every body of the space as ``(x, y, angle, vx, vy, ω)`` rows (order: :meth:`body_rows`), to write into.

        For a step group's ``before`` (one that is not ``direct``): the rows it changes are set
        in the space in one batch before the step is integrated (or before a ``direct`` group
        runs). The buffer holds the space as it is when the group gets it.
        """
        if not self._buffer_fresh:
            self._reader.read(self.space)
            self._buffer_fresh = True
        self._buffer_dirty = True
        return self._reader.every

    def _flush_buffer(self) -> None:
        if self._buffer_dirty:
            self._reader.write(self.space)
            self._buffer_dirty = False

    def state_bodies(self) -> list[pymunk.Body]:
        """The body of each state row, in row order."""
        return [entity.state_body for entity in self._stepped]

    def end_step_with(self, states: np.ndarray) -> None:
        """Finish a control step integrated outside :meth:`step` (:mod:`teamgym.sim.kernel`): ``states`` are the rows after it."""
        self.fine_steps += 1
        self._buffer_fresh = self._buffer_dirty = False  # the body buffer no longer holds the space
        self._take_states(states)
        self.time += self.dt

    def read_states(self) -> tuple[np.ndarray, np.ndarray]:
        """Refresh ``states`` and return ``(robot_states, mover_states)``, rows ``(x, y, angle, vx, vy, ω)``."""
        self._read()
        return self.robot_states, self.mover_states

    def _read(self) -> np.ndarray:
        if self._reader is None:
            self._reader = BodyReader(self.state_bodies())
        states = self._reader.read(self.space) if self._reader.bodies else np.zeros((0, 6))
        self._buffer_fresh = bool(self._reader.bodies)
        return self._take_states(states)

    def _take_states(self, states: np.ndarray) -> np.ndarray:
        empty = slice(0, 0)
        self.states = states
        self.robot_states = states[self._rows_of.get(Category.ROBOT, empty)]
        self.mover_states = states[self._rows_of.get(Category.OBSTACLE, empty)]
        return states

    def _integrate(self, h: float, n: int) -> None:
        """``n`` physics steps of length ``h``.

        The first goes through ``pymunk.Space.step`` when pymunk has deferred work (additions,
        removals, post-step callbacks, bodies to check); the rest, and the first when there is
        none, call Chipmunk's step directly, skipping about 3 µs of Python bookkeeping per
        substep. That is safe because nothing adds or removes objects during a control step
        (the contact callback only records).
        """
        space = self.space
        raw_step, handle = space_step, space._space
        if pending_work(space):
            space.step(h)
            n -= 1
        for _ in range(n):
            raw_step(handle, h)

    def _contact_free(self) -> bool:
        """Whether no contact can begin in the next control step (see ``coarse_substeps``)."""
        if self._contact_check is None:
            self._contact_check = self._prepare_contact_check()
        moving, fixed_boxes, may_touch = self._contact_check
        if not moving:
            return True
        grown = shape_bbs(moving)
        grown[:, :2] -= self.contact_reach
        grown[:, 2:] += self.contact_reach
        boxes = np.concatenate([grown, fixed_boxes]) if len(fixed_boxes) else grown
        meets = (
            (grown[:, None, 0] <= boxes[None, :, 2])
            & (boxes[None, :, 0] <= grown[:, None, 2])
            & (grown[:, None, 1] <= boxes[None, :, 3])
            & (boxes[None, :, 1] <= grown[:, None, 3])
        )
        return not (meets & may_touch).any()

    def _prepare_contact_check(self) -> tuple[list[pymunk.Shape], np.ndarray, np.ndarray]:
        """Shapes that move, bounding boxes of those that do not, and which pairs may collide."""
        moving = [(e, s) for e in self._stepped for s in e.shapes]
        fixed = [(e, s) for e in self.entities.values() if not e.has_state_row for s in e.shapes]
        everything = moving + fixed
        may_touch = np.array(
            [[ea is not eb and can_collide(sa.filter, sb.filter) for eb, sb in everything] for ea, sa in moving], dtype=bool
        ).reshape(len(moving), len(everything))
        return [s for _, s in moving], shape_bbs([s for _, s in fixed]), may_touch

    def _on_contact_begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        sa, sb = arbiter.shapes
        ea = getattr(sa, "entity", None)
        eb = getattr(sb, "entity", None)
        if ea is not None and eb is not None:
            self._contacts.record(Contact(ea.name, eb.name, ea.kind, eb.kind))
            self.coarse_contacts += self._coarse_now

    # -- contacts -------------------------------------------------------------------
    @property
    def contacts(self) -> list[Contact]:
        """Contacts that began during the last control step, in the order they began."""
        return self._contacts.last_step

    def contacts_of(self, name: str) -> list[Contact]:
        """Contacts of entity ``name`` that began in the last control step."""
        return [c for c in self.contacts if c.a == name or c.b == name]

    def new_contacts(self, name: str) -> int:
        """How many contacts of ``name`` began during the last control step (see :class:`ContactCounter`)."""
        return self._contacts.new.get(name, 0)

    def total_contacts(self, name: str) -> int:
        """How many contacts of ``name`` began since the world was built."""
        return self._contacts.total.get(name, 0)

    def contact_counts(self, total: bool = False) -> dict[str, int]:
        """``{name: count}`` for the last control step (with ``total``: since the world was built), nonzero counts only."""
        return dict(self._contacts.total if total else self._contacts.new)

    def contacts_per(self, names: Sequence[str], total: bool = False) -> np.ndarray:
        """Counts of :meth:`new_contacts` (or :meth:`total_contacts`) for ``names``, as an int64 array."""
        counts = self._contacts.total if total else self._contacts.new
        return np.array([counts.get(name, 0) for name in names], dtype=np.int64)

    # -- snapshots (TeamEnv's re-bases) ---------------------------------------------
    def fixed_record(self) -> FixedRecord:
        """The entities marked ``fixed`` (walls, furniture) with their bodies and shapes (see :class:`FixedRecord`)."""
        if self._fixed is None:
            self._fixed = FixedRecord([x for e in self.entities.values() if e.fixed for x in (e, *e.bodies, *e.shapes)])
        return self._fixed

    def release_fixed(self) -> None:
        """Take the fixed bodies and shapes out of the space, for a world restored from a snapshot to take them."""
        space = self.space
        for x in self.fixed_record().objects:  # shapes before their bodies (pymunk's remove, without its loop over types)
            if isinstance(x, pymunk.Shape):
                space._remove_shape(x)
        for x in self._fixed.objects:
            if isinstance(x, pymunk.Body):
                space._remove_body(x)

    def adopt_fixed(self, record: FixedRecord) -> None:
        """After unpickling a snapshot that referred to ``record``'s objects: they are this world's."""
        space = self.space
        for entity in record.objects:
            if isinstance(entity, Entity):
                entity.space = space
        self._fixed = record

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_fixed"] = None
        state["_plan"] = None  # step groups hold Chipmunk handles; made again on the next step
        state["_buffer_fresh"] = state["_buffer_dirty"] = False
        state["_buffer_writable"] = None
        return state


def pending_work(space: pymunk.Space) -> bool:
    """Whether ``pymunk.Space.step`` has work besides Chipmunk's step (pymunk 7's private lists of deferred work)."""
    return pending_work_in((space,))


def pending_work_in(spaces: Iterable[pymunk.Space]) -> bool:
    """Whether any of ``spaces`` has :func:`pending_work` (one call for a batch's spaces)."""
    for space in spaces:
        if (
            space._bodies_to_check
            or space._add_later
            or space._remove_later
            or space._post_step_callbacks
            or space._removed_shapes
            or getattr(space, "threaded", False)
        ):
            return True
    return False


class FixedRecord:
    """A world's fixed entities, each followed by its bodies and shapes (in the order added), pickled when first needed.

    A snapshot of the world refers to these objects instead of pickling them; a copy of the
    world gets fresh ones from :meth:`fresh`. Fixed entities never change once added, so the
    pickle, taken when a copy first needs it, holds them as they were at any earlier re-base.
    A record pickles as that pickle (``objects`` is then None) and deep-copies as itself.
    """

    def __init__(self, objects: list | None, data: tuple[int, bytes] | None = None) -> None:
        self.objects = objects
        self._data = data

    def data(self) -> tuple[int, bytes]:
        """The number of spaces the objects referred to (left out of the pickle) and the pickle."""
        if self._data is None:
            spaces = list({id(e.space): e.space for e in self.objects if isinstance(e, Entity) and e.space is not None}.values())
            self._data = (len(spaces), snapshot.dumps(self.objects, external=spaces))
        return self._data

    def fresh(self) -> FixedRecord:
        """New objects like these (in no space), with the same pickle."""
        n_spaces, data = self.data()
        return FixedRecord(snapshot.loads(data, external=[None] * n_spaces), (n_spaces, data))

    def __reduce__(self) -> tuple:
        return FixedRecord, (None, self.data())

    def __deepcopy__(self, memo: dict) -> FixedRecord:
        return self
