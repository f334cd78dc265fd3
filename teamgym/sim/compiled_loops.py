"""The numba-compiled loops of :mod:`teamgym.sim.kernel` (imported only when the kernel is used).

Importing this module imports numba and makes the Chipmunk functions of pymunk's extension
visible to numba's JIT linker (``llvmlite.binding.load_library_permanently``); each loop calls
them as external C functions by name, so the compiled code is cached on disk
(``cache=True``: numba's cache next to this file, or its user cache where that is read-only)
and later processes load it instead of compiling. Handles (pointers) are passed as ``uint64``;
a ``cpVect`` argument as two doubles and a ``cpShapeFilter`` as two machine words, which is how
the x86-64 System V and AAPCS64 calling conventions pass those structs
(:mod:`teamgym.sim.kernel` checks both against pymunk's own calls before using the loops).
"""

from __future__ import annotations

import llvmlite.binding
import numba
import pymunk
from numba import types

llvmlite.binding.load_library_permanently(pymunk._chipmunk.__file__)

_u64, _f64, _void = types.uint64, types.float64, types.void


def _c(name: str, result, *arguments) -> types.ExternalFunction:
    return types.ExternalFunction(name, result(*arguments))


space_step = _c("cpSpaceStep", _void, _u64, _f64)
each_body = _c("cpSpaceEachBody", _void, _u64, _u64, _u64)
set_position = _c("cpBodySetPosition", _void, _u64, _f64, _f64)
set_angle = _c("cpBodySetAngle", _void, _u64, _f64)
set_velocity = _c("cpBodySetVelocity", _void, _u64, _f64, _f64)
set_angular_velocity = _c("cpBodySetAngularVelocity", _void, _u64, _f64)
set_anchor_a = _c("cpPivotJointSetAnchorA", _void, _u64, _f64, _f64)
# (space, start, end, radius, filter, info*) -> cpShape*
segment_first = _c("cpSpaceSegmentQueryFirst", _u64, _u64, _f64, _f64, _f64, _f64, _f64, _u64, _u64, _u64)
# (space, point, max distance, filter, info*) -> cpShape*
point_nearest = _c("cpSpacePointQueryNearest", _u64, _u64, _f64, _f64, _f64, _u64, _u64, _u64)


@numba.njit(cache=True)
def step_worlds(
    spaces, floats_each, num, get_fn, get_data,
    bodies, values, movers, velocities, joints, anchors, substeps, h,
):  # fmt: skip
    """Set the control bodies, obstacle velocities and drive anchors; step every space; read every body.

    Returns 0, or 1 + the first world whose body count is not ``floats_each[m] / 6``.
    """
    for i in range(bodies.shape[0]):
        body = bodies[i]
        set_position(body, values[i, 0], values[i, 1])
        set_angle(body, values[i, 2])
        set_velocity(body, values[i, 3], values[i, 4])
        set_angular_velocity(body, values[i, 5])
    for i in range(movers.shape[0]):
        set_velocity(movers[i], velocities[i, 0], velocities[i, 1])
    for j in range(joints.shape[0]):
        set_anchor_a(joints[j], anchors[j, 0], anchors[j, 1])
    for m in range(spaces.shape[0]):
        for _ in range(substeps):
            space_step(spaces[m], h)
    total = 0
    for m in range(spaces.shape[0]):
        total += floats_each[m]
    failed = 0
    num[0] = 0
    for m in range(spaces.shape[0]):
        start = num[0]
        each_body(spaces[m], get_fn, get_data)
        if failed == 0 and num[0] - start != floats_each[m]:
            failed = m + 1
    num[0] = total
    return failed


@numba.njit(cache=True)
def cast(handles, groups, bits, ends, width, span, info, alpha, info_at, out):
    """``info[alpha] · span`` of each segment's first hit, ``span`` where it hits nothing (``width`` per space)."""
    for m in range(handles.shape[0]):
        for j in range(width):
            i = m * width + j
            hit = segment_first(
                handles[m], ends[4 * i], ends[4 * i + 1], ends[4 * i + 2], ends[4 * i + 3], 0.0, groups[m], bits[m], info_at
            )
            out[i] = info[alpha] * span if hit != 0 else span


@numba.njit(cache=True)
def near(handles, groups, bits, points, distances, info_at, out):
    """Whether any shape passing the filter lies within ``distances[m]`` of ``points[m]``."""
    for m in range(handles.shape[0]):
        out[m] = point_nearest(handles[m], points[m, 0], points[m, 1], distances[m], groups[m], bits[m], info_at) != 0
