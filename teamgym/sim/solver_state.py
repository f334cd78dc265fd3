"""The Chipmunk solver state pymunk's pickle leaves out, and a space that pickles it.

pymunk 7 pickles a space's bodies, shapes (with their hash ids), constraints, time stamp,
last time step and cached arbiters (contacts with their accumulated impulses). What else
decides the next substeps, and is not in its pickle:

* each body's bias velocity (``v_bias``, ``w_bias``): the overlap correction the last solve
  computed, which the next substep integrates into the position;
* the accumulated impulse ``jAcc`` of pivot and gear joints, the warm start of the next solve;
* the order of Chipmunk's constraint array, the order of the Gauss–Seidel sweeps (removing a
  constraint moves the last one into its slot; pymunk re-adds in the order they were added);
* which cached arbiters had separated: pymunk puts every restored arbiter in the list of
  touching pairs, so a pair that separated in the last substeps would not start a new contact
  (no ``begin``) if it touched again within the collision persistence.

:class:`SolverSpace` (the :class:`~teamgym.sim.world.World`'s space) adds these to its pickle
and puts them back, through the struct layouts of Munk2D 2.0 (``chipmunk_structs.h``, the
Chipmunk fork pymunk 7 is built on), which :func:`layout_matches` checks once against
pymunk's getters; where they do not match, the space pickles as pymunk's own. No pickle
restores the history of the broad phase (the bounding-box tree): the order in which it
reports colliding pairs can differ after unpickling, which changes the last bits when a body
has two or more contacts at once or a pair of shapes of one type touches.
"""

from __future__ import annotations

import math
from typing import Any

import cffi
import pymunk
from pymunk._chipmunk import ffi as _pymunk_ffi
from pymunk._chipmunk import lib as _lib
from pymunk.arbiter import _arbiter_from_dict

__all__ = ["SolverSpace", "layout_matches"]

_ffi = cffi.FFI()
_ffi.cdef(
    """
    typedef struct { double x, y; } tg_vect;
    typedef struct { int num, max; void **arr; } tg_array;
    typedef struct {
        void *velocity_func, *position_func;
        double m, m_inv, i, i_inv;
        tg_vect cog, p, v, f;
        double a, w, t;
        double transform[6];
        void *userData;
        tg_vect v_bias;
        double w_bias;
    } tg_body_head;
    typedef struct {
        void *klass, *space, *a, *b, *next_a, *next_b;
        double maxForce, errorBias, maxBias;
        unsigned char collideBodies;
        void *preSolve, *postSolve, *userData;
    } tg_constraint;
    typedef struct {
        tg_constraint constraint;
        tg_vect anchorA, anchorB, r1, r2;
        double k[4];
        tg_vect jAcc, bias;
    } tg_pivot;
    typedef struct {
        tg_constraint constraint;
        double phase, ratio, ratio_inv, iSum, bias, jAcc;
    } tg_gear;
    typedef struct {
        int iterations;
        tg_vect gravity;
        double damping, idleSpeedThreshold, sleepTimeThreshold, collisionSlop, collisionBias;
        unsigned int collisionPersistence;
        void *userData;
        unsigned int stamp;
        double curr_dt;
        tg_array *dynamicBodies, *staticBodies, *rousedBodies, *sleepingComponents;
        uintptr_t shapeIDCounter;
        void *staticShapes, *dynamicShapes;
        tg_array *constraints, *arbiters;
    } tg_space_head;
    """
)
_CACHED = 3  # CP_ARBITER_STATE_CACHED
_ARBITER = _pymunk_ffi.typeof("cpArbiter *")
_layout: bool | None = None


_UINTPTR, _OWN_UINTPTR = _pymunk_ffi.typeof("uintptr_t"), _ffi.typeof("uintptr_t")
_TYPES = {kind: _ffi.typeof(kind) for kind in ("tg_body_head *", "tg_pivot *", "tg_gear *", "tg_space_head *")}


def _cast(kind: str, handle: Any) -> Any:
    """``handle`` (a pymunk cffi pointer or an address) as a pointer to one of the structs above."""
    address = handle if isinstance(handle, int) else int(_pymunk_ffi.cast(_UINTPTR, handle))
    return _ffi.cast(_TYPES[kind], address)


def _address(pointer: Any) -> int:
    return int(_ffi.cast(_OWN_UINTPTR, pointer))


def _check_layout() -> bool:
    """Whether the struct layouts above are those of the linked Chipmunk (body, pivot, gear, space)."""
    space = pymunk.Space()
    space.iterations, space.gravity, space.damping = 7, (0.25, -0.5), 0.875
    space.collision_slop, space.collision_bias, space.collision_persistence = 2e-4, 0.125, 5
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.velocity, control.angular_velocity = (0.3, -0.2), 0.7
    body = pymunk.Body(2.0, 0.5)
    body.position, body.angle, body.velocity, body.angular_velocity = (1.5, -2.5), 0.25, (0.125, 0.75), -1.25
    pivot = pymunk.PivotJoint(control, body, (0.125, -0.25), (0.0625, 0.5))
    gear = pymunk.GearJoint(control, body, 0.375, 1.5)
    pivot.max_force, pivot.max_bias, pivot.error_bias = 0.6, 0.0, 0.25
    gear.max_force, gear.max_bias = 0.03, 0.0
    space.add(control, body, pivot, gear)
    b = _cast("tg_body_head *", body._body)
    before = (b.m, b.m_inv, b.i, b.i_inv, b.p.x, b.p.y, b.v.x, b.v.y, b.a, b.w, b.v_bias.x, b.v_bias.y, b.w_bias)
    if before != (2.0, 0.5, 0.5, 2.0, 1.5, -2.5, 0.125, 0.75, 0.25, -1.25, 0.0, 0.0, 0.0):
        return False
    space.step(0.01)
    head = _cast("tg_space_head *", space._space)
    p, g = _cast("tg_pivot *", pivot._constraint), _cast("tg_gear *", gear._constraint)
    rotation = body.rotation_vector
    return (
        (head.iterations, head.gravity.x, head.gravity.y, head.damping) == (7, 0.25, -0.5, 0.875)
        and (head.collisionSlop, head.collisionBias, head.collisionPersistence) == (2e-4, 0.125, 5)
        and (head.stamp, head.curr_dt) == (_lib.cpSpaceGetTimestamp(space._space), 0.01)
        and head.shapeIDCounter == _lib.cpSpaceGetShapeIDCounter(space._space)
        and (head.dynamicBodies.num, head.constraints.num, head.arbiters.num) == (2, 2, 0)
        and (b.p.x, b.p.y, b.a, b.w) == (*body.position, body.angle, body.angular_velocity)
        and (b.transform[0], b.transform[1], b.transform[4], b.transform[5]) == (*rotation, *body.position)
        and (p.constraint.maxForce, p.constraint.errorBias, p.constraint.maxBias) == (0.6, 0.25, 0.0)
        and (p.anchorA.x, p.anchorA.y, p.anchorB.x, p.anchorB.y) == (0.125, -0.25, 0.0625, 0.5)
        and (g.phase, g.ratio, g.ratio_inv) == (0.375, 1.5, 1.0 / 1.5)
        and pivot.impulse > 0.0
        and math.sqrt(p.jAcc.x * p.jAcc.x + p.jAcc.y * p.jAcc.y) == pivot.impulse
        and gear.impulse > 0.0
        and abs(g.jAcc) == gear.impulse
    )


def layout_matches() -> bool:
    """Whether this module can read and write the solver state of the linked Chipmunk (checked once)."""
    global _layout
    if _layout is None:
        _layout = _check_layout()
    return _layout


def _impulse(constraint: pymunk.Constraint) -> tuple[float, ...] | None:
    if isinstance(constraint, pymunk.PivotJoint):
        j = _cast("tg_pivot *", constraint._constraint).jAcc
        return (j.x, j.y)
    if isinstance(constraint, pymunk.GearJoint):
        return (_cast("tg_gear *", constraint._constraint).jAcc,)
    return None


def _set_impulse(constraint: pymunk.Constraint, impulse: tuple[float, ...] | None) -> None:
    if impulse is None:
        return
    if len(impulse) == 2:
        j = _cast("tg_pivot *", constraint._constraint).jAcc
        j.x, j.y = impulse
    else:
        _cast("tg_gear *", constraint._constraint).jAcc = impulse[0]


def capture(space: pymunk.Space) -> dict[str, Any]:
    """Bias velocities of the bodies that have one, and the constraints in Chipmunk's order with their impulses."""
    head = _cast("tg_space_head *", space._space)
    moving, biased = head.dynamicBodies, {}  # dynamic and kinematic bodies (static ones have no bias)
    for i in range(moving.num):
        b = _ffi.cast(_TYPES["tg_body_head *"], moving.arr[i])
        bias = (b.v_bias.x, b.v_bias.y, b.w_bias)
        if bias != (0.0, 0.0, 0.0):
            biased[_address(moving.arr[i])] = bias
    if biased:
        by_address = {int(_pymunk_ffi.cast(_UINTPTR, body._body)): body for body in space.bodies}
        biased = {by_address[address]: bias for address, bias in biased.items()}
    by_address = {int(_pymunk_ffi.cast(_UINTPTR, c._constraint)): c for c in space.constraints}
    array = head.constraints
    order = [by_address[_address(array.arr[i])] for i in range(array.num)]
    return {"bias": list(biased.items()), "constraints": [(c, _impulse(c)) for c in order]}


def restore(space: pymunk.Space, state: dict[str, Any]) -> None:
    """Put back what :func:`capture` took, and drop separated arbiters from the list of touching pairs."""
    entries = state["constraints"]
    order = [c for c, _ in entries]
    if order != list(space.constraints):
        space.remove(*order)
        space.add(*order)
    for constraint, impulse in entries:
        _set_impulse(constraint, impulse)
    for body, (vx, vy, w) in state["bias"]:
        b = _cast("tg_body_head *", body._body)
        b.v_bias.x, b.v_bias.y, b.w_bias = vx, vy, w
    touching = _cast("tg_space_head *", space._space).arbiters
    kept = 0
    for i in range(touching.num):
        arbiter = touching.arr[i]
        if _pymunk_ffi.cast(_ARBITER, _address(arbiter)).state != _CACHED:
            touching.arr[kept] = arbiter
            kept += 1
    touching.num = kept


class SolverSpace(pymunk.Space):
    """A ``pymunk.Space`` whose pickle also holds the solver state listed in the module docstring.

    Unpickling also gives every shape the hash id it had (pymunk's unpickle sets it, but adding
    the shape to the space draws a new one, which changes contact hashes once shapes have
    been removed): contacts of restored arbiters then match the new ones, as they would have.
    """

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        if layout_matches():
            state["special"].append(("teamgym_solver", capture(self)))
        return state

    def __setstate__(self, state: dict) -> None:
        later = ("shapes", "shapeIDCounter", "arbiters", "teamgym_solver")
        special = dict(state["special"])
        super().__setstate__({**state, "special": [(k, v) for k, v in state["special"] if k not in later]})
        handle, counter = self._space, _lib.cpSpaceGetShapeIDCounter(self._space)
        for shape in special["shapes"]:
            hashid = shape._hashid
            if hashid != counter:
                _lib.cpSpaceSetShapeIDCounter(handle, hashid)
            self._add_shape(shape)  # pymunk's add, without its loop over types
            counter = hashid + 1
        _lib.cpSpaceSetShapeIDCounter(handle, special["shapeIDCounter"])
        for arbiter in special["arbiters"]:
            _lib.cpSpaceAddCachedArbiter(self._space, _arbiter_from_dict(arbiter, self))
        if "teamgym_solver" in special and layout_matches():
            restore(self, special["teamgym_solver"])
