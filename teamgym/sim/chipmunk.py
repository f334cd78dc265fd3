"""Fast paths into Chipmunk for the simulation's hot loop.

pymunk's public property setters cost about 2 µs each in Python (a mixin ``__setattr__``,
an assert and the cffi call); driving five robots needs some fifty of them per control
step. These helpers call the same Chipmunk functions through pymunk's cffi handles
(``Body._body``, ``Constraint._constraint``, ``Space._space``), which are stable across
pymunk 7.x (the version range pinned in ``pyproject.toml``). ``tests/sim/test_sim_chipmunk.py``
checks them against the public API; ``test_ring_skip_gives_same_readings_as_casting_every_ray``
in ``tests/sim/test_sim_sensors.py`` checks the proximity ring built on :class:`RayCaster`.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pymunk
from pymunk import batch as _batch
from pymunk._chipmunk import lib as _lib

space_step = _lib.cpSpaceStep
_BODY_FIELDS = (
    _batch.BodyFields.BODY_ID
    | _batch.BodyFields.POSITION
    | _batch.BodyFields.ANGLE
    | _batch.BodyFields.VELOCITY
    | _batch.BodyFields.ANGULAR_VELOCITY
)


def set_kinematic_motion(
    body: pymunk.Body, position: tuple[float, float], angle: float, velocity: tuple[float, float], angular_velocity: float
) -> None:
    """Set position, angle, velocity and angular velocity of a (kinematic) body in one go."""
    handle = body._body
    _lib.cpBodySetPosition(handle, position)
    _lib.cpBodySetAngle(handle, angle)
    _lib.cpBodySetVelocity(handle, velocity)
    _lib.cpBodySetAngularVelocity(handle, angular_velocity)


def kinematic_setters() -> tuple:
    """Chipmunk's body setters of position, angle, velocity and angular velocity (they take ``body._body``)."""
    return _lib.cpBodySetPosition, _lib.cpBodySetAngle, _lib.cpBodySetVelocity, _lib.cpBodySetAngularVelocity


def set_pivot_anchor_a(pivot: pymunk.PivotJoint, anchor: tuple[float, float]) -> None:
    """Set a pivot joint's anchor on its first body (local coordinates)."""
    _lib.cpPivotJointSetAnchorA(pivot._constraint, anchor)


_ffi = pymunk._chipmunk.ffi
_NULL = _ffi.NULL
_FLOAT_SIZE = _ffi.sizeof("cpFloat")
_INT_SIZE = _ffi.sizeof("uintptr_t")


class BatchArrays:
    """The two C arrays pymunk's batch functions fill, freed when this object is.

    Duck-types the ``_float_arr`` / ``_int_arr`` of ``pymunk.batch.Buffer``, which
    ``pymunk.batch.get_space_bodies`` fills. pymunk 7's own ``Buffer`` allocates them with
    ``pmFloatArrayNew`` / ``pmIntArrayNew`` and never frees them: each ``Buffer`` leaks
    arrays grown to a row for every body of the space it read (static wall bodies
    included), about 27 kB per Rendezvous-v0 world. Here ``ffi.gc`` hands them to
    ``pmFloatArrayFree`` / ``pmIntArrayFree`` (which free the data and the array).
    """

    __slots__ = ("_float_arr", "_int_arr")

    def __init__(self) -> None:
        self._float_arr = _ffi.gc(_lib.pmFloatArrayNew(0), _lib.pmFloatArrayFree)
        self._int_arr = _ffi.gc(_lib.pmIntArrayNew(0), _lib.pmIntArrayFree)

    def clear(self) -> None:
        """Mark both arrays empty; their memory is kept for the next fill."""
        self._float_arr.num = 0
        self._int_arr.num = 0

    def floats(self) -> np.ndarray:
        """The float array's values (a view, valid until the next fill)."""
        arr = self._float_arr
        return np.frombuffer(_ffi.buffer(arr.arr, _FLOAT_SIZE * arr.num), dtype=np.float64)

    def ints(self) -> np.ndarray:
        """The integer array's values (a view, valid until the next fill)."""
        arr = self._int_arr
        return np.frombuffer(_ffi.buffer(arr.arr, _INT_SIZE * arr.num), dtype=np.uintp)


_GET_BODIES = _ffi.addressof(_lib, "pmSpaceBodyGetIteratorFuncBatched")


def body_poses(bodies: list[pymunk.Body]) -> list[tuple[float, float, float]]:
    """``(x, y, angle)`` of each body through Chipmunk's getters (the doubles ``body.position`` and ``body.angle``
    give, without a ``Vec2d`` per body)."""
    get_position, get_angle = _lib.cpBodyGetPosition, _lib.cpBodyGetAngle
    poses = []
    for body in bodies:
        handle = body._body
        p = get_position(handle)
        poses.append((p.x, p.y, get_angle(handle)))
    return poses


def body_ids(space: pymunk.Space) -> list[int]:
    """Ids of the space's bodies in Chipmunk's iteration order (the order of pymunk's batch iterators)."""
    arrays = BatchArrays()
    data = _ffi.new("pmBatchedData *")
    data.fields = _batch.BodyFields.BODY_ID.value
    data.floatArray = arrays._float_arr
    data.intArray = arrays._int_arr
    _lib.cpSpaceEachBody(space._space, _GET_BODIES, data)
    return arrays.ints().tolist()


_SET_BODIES = _ffi.addressof(_lib, "pmSpaceBodySetIteratorFuncBatched")
_MOTION_FIELDS = _BODY_FIELDS & ~_batch.BodyFields.BODY_ID


class BodyReader:
    """Reads ``(x, y, angle, vx, vy, ω)`` of chosen bodies of a space in one batch call, and writes bodies back.

    Rows come back in the order of ``bodies``. The mapping from the space's body order is
    computed on the first read; make a new reader after adding or removing bodies (the
    :class:`~teamgym.sim.world.World` does this).

    After a read, :attr:`every` holds the rows of every body of the space in the space's own
    order (a writable view of the C array, valid until the next read); :meth:`rows_of` gives
    the rows of chosen bodies in it, and :meth:`write` sets every body of the space from it in
    one ``pymunk.batch.set_space_bodies`` pass (the same Chipmunk setters as pymunk's
    properties). Writing back a row unchanged leaves its body bit for bit as it was when the
    body's centre of gravity is its origin (``writable``; every teamgym body is built so).
    """

    def __init__(self, bodies: list[pymunk.Body]) -> None:
        self.bodies = list(bodies)
        self._setup()

    def _setup(self) -> None:
        self.ids = np.array([b.id for b in self.bodies], dtype=np.uintp)
        self._rows: np.ndarray | None = None
        self._arrays = BatchArrays()
        self._get = self._batch_data(_BODY_FIELDS)
        self._set = self._batch_data(_MOTION_FIELDS)
        self._all_ids: np.ndarray | None = None
        self._direct: bool | None = None  # read body by body (decided at the first read)
        #: Rows of every body of the space after the last read (see the class docstring).
        self.every = np.zeros((0, 6))

    def _batch_data(self, fields: _batch.BodyFields):
        data = _ffi.new("pmBatchedData *")
        data.fields = fields.value
        data.floatArray = self._arrays._float_arr
        data.intArray = self._arrays._int_arr
        return data

    #: A space with more bodies than this many per chosen body (plus :data:`DIRECT_SLACK`) is read
    #: body by body: one batch pass visits every body of the space, static walls included (a
    #: Rendezvous map holds hundreds), and costs more than a few getter calls per chosen body.
    DIRECT_RATIO: ClassVar[int] = 4
    DIRECT_SLACK: ClassVar[int] = 16

    def read(self, space: pymunk.Space) -> np.ndarray:
        """Array of shape ``(len(bodies), 6)``: x, y, angle, vx, vy, angular velocity."""
        direct = self._direct
        if direct is None:
            direct = self._direct = len(space.bodies) > self.DIRECT_RATIO * len(self.bodies) + self.DIRECT_SLACK
        if direct:
            return self._read_direct()
        arrays = self._arrays
        arrays.clear()
        _lib.cpSpaceEachBody(space._space, _GET_BODIES, self._get)
        values = arrays.floats().reshape(-1, 6)
        self.every = values
        if self._rows is None:
            ids = arrays.ints().copy()
            order = np.argsort(ids)
            found = np.minimum(np.searchsorted(ids, self.ids, sorter=order), len(ids) - 1)
            rows = order[found]
            if not np.array_equal(ids[rows], self.ids):
                raise KeyError("BodyReader: some bodies are not in the space")
            self._rows, self._all_ids = rows, ids
        return values[self._rows]

    def _read_direct(self) -> np.ndarray:
        """The chosen bodies' rows through Chipmunk's getters (the doubles a batch pass copies); :attr:`every` stays empty."""
        rows = []
        for body in self.bodies:
            handle = body._body
            p, v = _lib.cpBodyGetPosition(handle), _lib.cpBodyGetVelocity(handle)
            rows.append((p.x, p.y, _lib.cpBodyGetAngle(handle), v.x, v.y, _lib.cpBodyGetAngularVelocity(handle)))
        return np.array(rows, dtype=np.float64).reshape(-1, 6)

    def rows_of(self, bodies: list[pymunk.Body]) -> np.ndarray:
        """Rows of ``bodies`` in :attr:`every` (after the first read); ``KeyError`` for a body not in the space."""
        if self._all_ids is None:
            raise RuntimeError("BodyReader.rows_of before the first read")
        index = {int(body_id): row for row, body_id in enumerate(self._all_ids.tolist())}
        try:
            return np.array([index[b.id] for b in bodies], dtype=np.intp)
        except KeyError:
            raise KeyError("BodyReader.rows_of: some bodies are not in the space") from None

    def writable(self, space: pymunk.Space) -> bool:
        """Whether :meth:`write` may be used: the space holds the bodies last read, each with its centre of gravity at 0."""
        return (
            self._all_ids is not None
            and len(space.bodies) == len(self._all_ids)
            and all(tuple(b.center_of_gravity) == (0.0, 0.0) for b in space.bodies)
        )

    def write(self, space: pymunk.Space) -> None:
        """Set position, angle, velocity and angular velocity of every body of ``space`` from :attr:`every`."""
        floats = self._arrays._float_arr
        if floats.num != 6 * len(self._all_ids):
            raise RuntimeError("BodyReader.write: the space's bodies changed since the last read")
        floats.num = 0  # pymunk's set iterator pops from the front
        try:
            _lib.cpSpaceEachBody(space._space, _SET_BODIES, self._set)
        finally:
            floats.num = 6 * len(self._all_ids)

    def __getstate__(self) -> dict:
        return {"bodies": self.bodies}

    def __setstate__(self, state: dict) -> None:
        # Body ids are memory addresses: they change when a space is unpickled.
        self.bodies = state["bodies"]
        self._setup()


_POINT_INFO = _ffi.new("cpPointQueryInfo *")


def shape_bbs(shapes: list[pymunk.Shape]) -> np.ndarray:
    """``(len(shapes), 4)`` bounding boxes ``(left, bottom, right, top)`` as Chipmunk last computed them."""
    get_bb = _lib.cpShapeGetBB
    boxes = [get_bb(shape._shape) for shape in shapes]
    return np.array([(bb.l, bb.b, bb.r, bb.t) for bb in boxes], dtype=float).reshape(len(shapes), 4)


def can_collide(a: pymunk.ShapeFilter, b: pymunk.ShapeFilter) -> bool:
    """Chipmunk's filter test (``cpShapeFilterReject`` negated): whether shapes with these filters may touch."""
    if a.group != 0 and a.group == b.group:
        return False
    return bool(a.categories & b.mask) and bool(b.categories & a.mask)


def shape_distance(shape: pymunk.Shape, point: tuple[float, float]) -> float:
    """``shape.point_query(point).distance`` (negative inside) without building pymunk's result objects."""
    return _lib.cpShapePointQuery(shape._shape, point, _POINT_INFO)


class RayCaster:
    """First-hit segment queries without building pymunk result objects.

    ``cast(space, start, end, shape_filter)`` returns the hit fraction ``alpha`` in
    ``[0, 1]`` along the segment, or ``None`` when nothing is hit; the hit shape's owner
    is not needed by the proximity ring, which is what this serves.
    """

    def __init__(self) -> None:
        self._info = _ffi.new("cpSegmentQueryInfo *")
        self._near = _ffi.new("cpPointQueryInfo *")

    def anything_within(
        self, space: pymunk.Space, point: tuple[float, float], distance: float, shape_filter: pymunk.ShapeFilter
    ) -> bool:
        """Whether any shape passing ``shape_filter`` lies within ``distance`` of ``point``."""
        return _lib.cpSpacePointQueryNearest(space._space, point, distance, shape_filter, self._near) != _NULL

    def cast(
        self, space: pymunk.Space, start: tuple[float, float], end: tuple[float, float], shape_filter: pymunk.ShapeFilter
    ) -> float | None:
        info = self._info
        if _lib.cpSpaceSegmentQueryFirst(space._space, start, end, 0.0, shape_filter, info) == _NULL:
            return None
        return info.alpha

    def cast_rays(self, space: pymunk.Space, rays: list, filters: list[pymunk.ShapeFilter]) -> list[float | None]:
        """:meth:`cast` of every ray ``(x0, y0, x1, y1)`` with its filter, in one loop: hit fractions or ``None``."""
        query, handle, info, null = _lib.cpSpaceSegmentQueryFirst, space._space, self._info, _NULL
        alphas: list[float | None] = []
        for (x0, y0, x1, y1), shape_filter in zip(rays, filters):
            alphas.append(info.alpha if query(handle, (x0, y0), (x1, y1), 0.0, shape_filter, info) != null else None)
        return alphas

    def ray_distances(
        self, spaces: list[pymunk.Space], ends: list[float], filters: list[pymunk.ShapeFilter], width: int, span: float
    ) -> list[float]:
        """``alpha · span`` of each ray's first hit (``span`` where it hits nothing), ``width`` rays per group.

        Group ``m`` casts in ``spaces[m]`` with ``filters[m]``; ``ends`` is flat: ray ``j`` of group ``m`` is
        ``x0, y0, x1, y1`` at ``4 (m · width + j)`` (a flat list converts from numpy far faster than nested
        ones). :meth:`cast_rays` of every group, in one loop; the result is flat in the same order.
        """
        query, info, null = _lib.cpSpaceSegmentQueryFirst, self._info, _NULL
        out: list[float] = []
        at = 0
        for space, shape_filter in zip(spaces, filters):
            handle = space._space
            for _ in range(width):
                x0, y0, x1, y1 = ends[at : at + 4]
                at += 4
                out.append(info.alpha * span if query(handle, (x0, y0), (x1, y1), 0.0, shape_filter, info) != null else span)
        return out

    def __getstate__(self) -> dict:
        return {}

    def __setstate__(self, state: dict) -> None:
        self.__init__()
