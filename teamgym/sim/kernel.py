"""Compiled loops over many worlds' Chipmunk calls: the physics and the rays of a batch's control step.

Worlds that step together (:mod:`teamgym.sim.world_group`) each make, per control step, four
setter calls per control body, an anchor call per robot drive, ``substeps`` calls of
``cpSpaceStep`` and one batch read of their bodies; the proximity rings of their robots make a
nearest-shape query per robot and a segment query per ray. From Python each call costs a
quarter of a microsecond or more of interpreter work besides Chipmunk's own (Navigation, 64
copies: the physics phase took 60 µs per copy-step in Python and 44 µs compiled,
``TEAMGYM_KERNEL=1`` / ``0 python benchmarks/bench_batch_phases.py --env Navigation-v0 --copies 64``).
Here numba (the ``fast`` extra: ``pip install teamgym[fast]``) compiles those loops
(:mod:`teamgym.sim.compiled_loops`, cached on disk after the first process); they call the same
functions exported by pymunk's Chipmunk library, with the same arguments in the same order per
body, so the numbers they leave are the Python path's, bit for bit (``tests/sim/test_sim_kernel.py``
compares both on batches of every kind of world).

Without numba, on Windows (where a ``cpVect`` argument is passed by reference) or with the
environment variable ``TEAMGYM_KERNEL=0``, :func:`enabled` is false and everything runs in
Python. Two ABI facts are relied on and checked once per process against pymunk's own calls
(:func:`_self_test`, :func:`_queries_agree`; a failed check turns the kernel off): a ``cpVect``
passed by value is two doubles in floating-point registers, and a ``cpShapeFilter`` (a
pointer-sized group, two 32-bit masks) two integer words (x86-64 System V and AAPCS64 alike).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pymunk
from pymunk._chipmunk import ffi as _ffi
from pymunk._chipmunk import lib as _lib

from teamgym.sim.chipmunk import _GET_BODIES, _MOTION_FIELDS, body_ids

__all__ = [
    "KernelError",
    "SpaceLayout",
    "WorldsKernel",
    "body_handles",
    "enabled",
    "filter_words",
    "first_hits",
    "joint_handles",
    "set_enabled",
    "shapes_within",
    "space_handles",
]

#: ``TEAMGYM_KERNEL=0`` in the environment turns the compiled path off for the process.
ENV_FLAG = "TEAMGYM_KERNEL"
_switch: dict[str, bool] = {"on": os.environ.get(ENV_FLAG, "1").strip().lower() not in ("0", "false", "no", "off")}


class KernelError(RuntimeError):
    """A world's bodies changed under a :class:`WorldsKernel` (its layout must be made again)."""


def set_enabled(on: bool) -> None:
    """Turn the compiled path on or off for this process (tests compare both paths)."""
    _switch["on"] = bool(on)


def enabled() -> bool:
    """Whether the compiled paths are used (numba importable, ABI checked, not switched off)."""
    return _switch["on"] and _compiled() is not None and _compiled_queries() is not None


def _address(handle: object) -> int:
    return int(_ffi.cast("uintptr_t", handle))


@lru_cache(maxsize=1)
def _loops():
    """:mod:`teamgym.sim.compiled_loops` (imports numba), or ``None`` where it cannot be used."""
    if sys.platform == "win32" or sys.byteorder != "little":
        return None
    try:
        from teamgym.sim import compiled_loops
    except Exception:  # noqa: BLE001 - no numba, a numba that refuses this numpy, a library it cannot load
        return None
    return compiled_loops


@lru_cache(maxsize=1)
def _compiled():
    """The compiled step function, or ``None`` where it cannot be used (checked once per process)."""
    loops = _loops()
    if loops is None:
        return None
    return loops.step_worlds if _self_test(loops.step_worlds) else None


@lru_cache(maxsize=1)
def _compiled_queries():
    """The compiled segment and nearest-point queries, or ``None`` where they cannot be used (checked once per process)."""
    loops = _loops()
    if loops is None or _compiled() is None:
        return None
    return (loops.cast, loops.near) if _queries_agree(loops.cast, loops.near) else None


def _queries_agree(cast, near) -> bool:
    """Whether the compiled queries give pymunk's answers on a scratch space (the ``cpShapeFilter`` words above)."""
    from teamgym.sim.chipmunk import RayCaster

    try:
        space = pymunk.Space()
        for k, (x, y) in enumerate([(0.5, 0.0), (0.0, 0.75), (-0.4, -0.3)]):
            body = pymunk.Body(body_type=pymunk.Body.STATIC)
            body.position = (x, y)
            circle = pymunk.Circle(body, 0.1)
            circle.filter = pymunk.ShapeFilter(group=k, categories=1 << k, mask=0xFFFFFFFF)
            space.add(body, circle)
        filters = [pymunk.ShapeFilter(group=1, categories=1, mask=0b101), pymunk.ShapeFilter(mask=0b010)]
        words = np.array([filter_words(f) for f in filters], dtype=np.uint64)
        handles = np.array([_address(space._space)] * 2, dtype=np.uint64)
        ends = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -0.8, -0.6]] * 2, dtype=np.float64)
        out = np.empty(6)
        cast(handles, words[:, 0], words[:, 1], ends.ravel(), 3, 2.0, _INFO, _ALPHA, _INFO.ctypes.data, out)
        caster = RayCaster()
        expected = caster.ray_distances([space] * 2, ends.ravel().tolist(), filters, 3, 2.0)
        points, reach = np.array([[0.5, 0.3], [0.5, 0.3]]), np.array([0.25, 0.25])
        found = np.empty(2, dtype=np.bool_)
        near(handles, words[:, 0], words[:, 1], points, reach, _INFO.ctypes.data, found)
        nearby = [caster.anything_within(space, (0.5, 0.3), 0.25, f) for f in filters]
        return out.tolist() == expected and found.tolist() == nearby and expected != [2.0] * 6 and nearby == [True, False]
    except Exception:  # noqa: BLE001 - any failure means: do not use the compiled queries
        return False


#: Index of ``alpha`` among the six doubles of a ``cpSegmentQueryInfo`` (shape pointer, point, normal, alpha).
_ALPHA = _ffi.offsetof("cpSegmentQueryInfo", "alpha") // 8
_INFO = np.zeros(max(6, _ffi.sizeof("cpSegmentQueryInfo") // 8, _ffi.sizeof("cpPointQueryInfo") // 8 + 1), dtype=np.float64)


def filter_words(shape_filter: pymunk.ShapeFilter) -> tuple[int, int]:
    """A ``cpShapeFilter`` as the two machine words it is passed in: the group, then categories and mask."""
    return int(shape_filter.group), int(shape_filter.categories) | (int(shape_filter.mask) << 32)


def first_hits(
    handles: np.ndarray, groups: np.ndarray, bits: np.ndarray, ends: np.ndarray, width: int, span: float
) -> np.ndarray:
    """``alpha · span`` of each segment's first hit (``span`` where it hits nothing): :meth:`RayCaster.ray_distances
    <teamgym.sim.chipmunk.RayCaster.ray_distances>` compiled.

    ``ends`` is flat, ``x0, y0, x1, y1`` per segment; ``width`` segments per space ``handles[m]``,
    cast with filter words ``groups[m]``, ``bits[m]`` (:func:`filter_words`).
    """
    cast, _ = _compiled_queries()
    out = np.empty(len(handles) * width, dtype=np.float64)
    cast(handles, groups, bits, ends, int(width), float(span), _INFO, _ALPHA, _INFO.ctypes.data, out)
    return out


def shapes_within(
    handles: np.ndarray, groups: np.ndarray, bits: np.ndarray, points: np.ndarray, distances: np.ndarray
) -> np.ndarray:
    """Whether any shape passing the filter lies within ``distances[m]`` of ``points[m]`` in space ``handles[m]``."""
    _, near = _compiled_queries()
    out = np.empty(len(handles), dtype=np.bool_)
    near(handles, groups, bits, points, distances, _INFO.ctypes.data, out)
    return out


def space_handles(spaces: Sequence[pymunk.Space]) -> np.ndarray:
    """Chipmunk handles of pymunk spaces, for the compiled functions."""
    return np.array([_address(space._space) for space in spaces], dtype=np.uint64)


@dataclass(frozen=True)
class SpaceLayout:
    """A space's Chipmunk handle and its bodies in Chipmunk's iteration order (``rows``: body id → row)."""

    handle: int
    rows: dict[int, int]

    @classmethod
    def of(cls, space: pymunk.Space) -> SpaceLayout:
        return cls(_address(space._space), {body_id: row for row, body_id in enumerate(body_ids(space))})

    def body_rows(self, bodies: Sequence[pymunk.Body]) -> np.ndarray:
        """Rows of ``bodies`` in the space's iteration order; ``KeyError`` for a body not in the space."""
        rows = self.rows
        return np.array([rows[body.id] for body in bodies], dtype=np.intp)


class WorldsKernel:
    """The bodies of several worlds in one float buffer, and the compiled step over them.

    :attr:`buffer` holds ``(x, y, angle, vx, vy, ω)`` of every body of every space, world after
    world, each in Chipmunk's iteration order; :meth:`body_rows` finds bodies in it. :meth:`step`
    sets the control bodies, obstacle velocities and drive anchors it is given (Chipmunk's
    setters, as pymunk's properties call them), integrates ``substeps`` substeps of ``h`` in
    every space and reads every body into :attr:`buffer`. ``spaces`` are pymunk spaces or their
    :class:`SpaceLayout` (made once per space and reused while its bodies stay).
    """

    def __init__(self, spaces: Sequence[pymunk.Space | SpaceLayout], function=None) -> None:
        self._step = function if function is not None else _compiled()
        if self._step is None:
            raise KernelError("the compiled step kernel is not available (see teamgym.sim.kernel.enabled)")
        layouts = [s if isinstance(s, SpaceLayout) else SpaceLayout.of(s) for s in spaces]
        handles = np.array([layout.handle for layout in layouts], dtype=np.uint64)
        self._allocate(layouts, handles, np.array([len(layout.rows) for layout in layouts], dtype=np.int64))

    def subset(self, worlds: np.ndarray) -> WorldsKernel:
        """A kernel over the worlds ``worlds`` (indices, ascending) of this one, with a buffer of its own."""
        kernel = object.__new__(WorldsKernel)
        kernel._step = self._step
        kernel._allocate([self.layouts[m] for m in worlds.tolist()], self.handles[worlds], self.counts[worlds])
        return kernel

    def _allocate(self, layouts: list[SpaceLayout], handles: np.ndarray, counts: np.ndarray) -> None:
        self.layouts, self.handles, self.counts = layouts, handles, counts
        self.offsets = np.concatenate([[0], np.cumsum(self.counts)]).astype(np.int64)
        total = int(self.offsets[-1])
        # Room for twice the bodies: a world that gains bodies is caught before the array would move.
        self._floats = _ffi.gc(_lib.pmFloatArrayNew(12 * total + 64), _lib.pmFloatArrayFree)
        self._ints = _ffi.gc(_lib.pmIntArrayNew(0), _lib.pmIntArrayFree)
        self._data = _ffi.new("pmBatchedData *")
        self._data.fields = _MOTION_FIELDS.value
        self._data.floatArray = self._floats
        self._data.intArray = self._ints
        self._num = np.frombuffer(_ffi.buffer(self._floats, 4), dtype=np.int32)
        self._array_at = _address(self._floats.arr)
        capacity = int(self._floats.max)
        self.buffer = np.frombuffer(_ffi.buffer(self._floats.arr, 8 * capacity), dtype=np.float64)[: 6 * total].reshape(total, 6)
        self._args = (self.handles, 6 * self.counts, self._num, _address(_GET_BODIES), _address(self._data))
        self._nothing = (_NO_HANDLES, _NO_ROWS, _NO_HANDLES, _NO_PAIRS, _NO_HANDLES, _NO_PAIRS)

    def body_rows(self, m: int, bodies: Sequence[pymunk.Body]) -> np.ndarray:
        """Rows of ``bodies`` of world ``m`` in :attr:`buffer`; ``KeyError`` for a body not in its space."""
        return self.layouts[m].body_rows(bodies) + int(self.offsets[m])

    def step(
        self,
        bodies: np.ndarray,
        values: np.ndarray,
        movers: np.ndarray,
        velocities: np.ndarray,
        joints: np.ndarray,
        anchors: np.ndarray,
        substeps: int,
        h: float,
    ) -> np.ndarray:
        """One control step of every world; returns :attr:`buffer` (every body after the step).

        ``bodies``/``values``: body handles (:func:`body_handles`) set to ``(x, y, angle, vx, vy, ω)``;
        ``movers``/``velocities``: bodies whose velocity is set; ``joints``/``anchors``: pivot joints
        (:func:`joint_handles`) and their first anchors. The worlds are stepped in any case; a world
        whose body count changed since this kernel was made raises :class:`KernelError` after the
        step (:attr:`buffer` is then stale: make a new kernel and :meth:`read`).
        """
        failed = self._step(*self._args, bodies, values, movers, velocities, joints, anchors, int(substeps), float(h))
        return self._checked(failed)

    def read(self) -> np.ndarray:
        """Every body of every world into :attr:`buffer` (no step); returns it."""
        return self._checked(self._step(*self._args, *self._nothing, 0, 0.0))

    def _checked(self, failed: int) -> np.ndarray:
        if failed:
            raise KernelError(f"WorldsKernel: the bodies of world {failed - 1} changed since the kernel was made")
        if _address(self._floats.arr) != self._array_at:  # the count check above comes first; kept as a guard
            raise KernelError("WorldsKernel: the float array moved")
        return self.buffer


_NO_HANDLES = np.zeros(0, dtype=np.uint64)
_NO_ROWS = np.zeros((0, 6))
_NO_PAIRS = np.zeros((0, 2))


def body_handles(bodies: Sequence[pymunk.Body]) -> np.ndarray:
    """Chipmunk handles of pymunk bodies, for :meth:`WorldsKernel.step`."""
    return np.array([_address(body._body) for body in bodies], dtype=np.uint64)


def joint_handles(joints: Sequence[pymunk.Constraint]) -> np.ndarray:
    """Chipmunk handles of pymunk constraints, for :meth:`WorldsKernel.step`."""
    return np.array([_address(joint._constraint) for joint in joints], dtype=np.uint64)


def _self_test(step_worlds) -> bool:
    """Whether the compiled step leaves two scratch spaces as pymunk's own setters and step do (the ABI facts above)."""
    try:
        spaces = [_scratch_space(k) for k in range(2)]
        twins = [space.copy() for space in spaces]
        kernel = WorldsKernel(spaces, function=step_worlds)
        motion = np.array([[0.5, -0.25, 0.75, 0.125, -0.375, 1.5]])
        joints = joint_handles([_pivot_of(space) for space in spaces])
        anchors = np.array([[0.375, -0.75], [-0.125, 0.625]])
        controls, discs = body_handles([_control_of(spaces[1])]), body_handles([_disc_of(spaces[0])])
        buffer = kernel.step(controls, motion, discs, np.array([[0.25, -0.5]]), joints, anchors, 3, 0.01)
        control = _control_of(twins[1])
        control.position, control.angle = (0.5, -0.25), 0.75
        control.velocity, control.angular_velocity = (0.125, -0.375), 1.5
        _disc_of(twins[0]).velocity = (0.25, -0.5)
        for space, anchor in zip(twins, anchors.tolist()):
            _pivot_of(space).anchor_a = anchor
            for _ in range(3):
                space.step(0.01)
        rows = [tuple(row) for row in buffer.tolist()]
        return (
            all(_body_rows(a) == _body_rows(b) for a, b in zip(spaces, twins))
            and rows == [row for space in spaces for row in _body_rows(space)]
            and all(tuple(_pivot_of(a).anchor_a) == tuple(_pivot_of(b).anchor_a) for a, b in zip(spaces, twins))
        )
    except Exception:  # noqa: BLE001 - any failure means: do not use the kernel
        return False


def _scratch_space(k: int) -> pymunk.Space:
    """A disc dragged by a kinematic body through a pivot joint (as a robot's drive), for :func:`_self_test`."""
    space = pymunk.Space()
    disc = pymunk.Body(1.0, 1.0)
    disc.position, disc.velocity = (0.25 + k, -0.5), (0.125, 0.0625)
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = (0.25 + k, -0.5)
    space.add(disc, pymunk.Circle(disc, 0.1), control, pymunk.PivotJoint(control, disc, (0.0, 0.0), (0.0, 0.0)))
    return space


def _disc_of(space: pymunk.Space) -> pymunk.Body:
    return next(body for body in space.bodies if body.body_type == pymunk.Body.DYNAMIC)


def _control_of(space: pymunk.Space) -> pymunk.Body:
    return next(body for body in space.bodies if body.body_type == pymunk.Body.KINEMATIC)


def _pivot_of(space: pymunk.Space) -> pymunk.PivotJoint:
    return next(iter(space.constraints))


def _body_rows(space: pymunk.Space) -> list[tuple]:
    """``(x, y, angle, vx, vy, ω)`` of the space's bodies in Chipmunk's iteration order."""
    order = {body.id: body for body in space.bodies}
    return [(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in (order[i] for i in body_ids(space))]
