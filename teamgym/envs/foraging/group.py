"""Foraging's state, sensing and go-to control as numpy passes over a group of copies (a batch's step).

A lone :class:`~teamgym.envs.foraging.env.Foraging` env computes each phase robot by robot in
scalar float arithmetic, which is cheapest for its two or three robots. A
:class:`~teamgym.envs.batch.TeamBatch` of K copies runs the same phases here, once over every
robot of every copy (arrays ``(K, n, ...)`` from the copies' rows of the shared
:class:`~teamgym.envs.foraging.state.ForagingArrays`), with the same IEEE operations in the
same order, so every copy ends each step bit for bit as the lone env with its seed:

* :func:`advance_odometry`: the odometry of eq. (2) (:meth:`Odometry.advance_rows
  <teamgym.envs.foraging.perception.Odometry.advance_rows>`);
* :func:`view_geometry`: the cameras' offsets and distances (:meth:`Cameras.look
  <teamgym.envs.foraging.sensing.Cameras.look>`);
* :func:`presence`: who is at which target (``Foraging._update_presence``);
* :func:`perceive_copies`: sightings, occlusion, measurement errors, re-localisation at
  landmarks and the perception tuples of eq. (1) (:func:`~teamgym.envs.foraging.sensing.perceive`);
* :func:`goto_copies`: the go-to-cell controller (``Foraging.goto_commands`` and
  :meth:`GoToController.command_pairs <teamgym.envs.foraging.controller.GoToController.command_pairs>`).

Random draws stay each copy's own: one call per copy on its generator, of the size and in
the order the lone env draws. ``atan2``, ``cos``, ``sin`` and ``pow`` are Python's ``math``
(libm) element by element, as the lone env computes them: numpy's AVX-512 kernels of
``arctan2`` and ``power`` differ from libm in the last bit on some machines.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from teamgym.envs.foraging.controller import GoToController
from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.perception import (
    _PV_ROWS,
    BEARING_ERROR,
    DISTANCE_ERROR,
    ROBOT,
    SENDER,
    TARGET,
    VisionModel,
)
from teamgym.envs.foraging.sensing import NO_CELL, cells_of
from teamgym.sim.libm import libm

__all__ = [
    "CopyView",
    "advance_odometry",
    "goto_copies",
    "perceive_copies",
    "presence",
    "view_geometry",
    "wrap_angle",
]

_PI, _TWO_PI = math.pi, 2 * math.pi
_PV = np.array(_PV_ROWS)


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """``(angle + π) % 2π − π`` (in place on ``angle``, which the caller owns)."""
    angle += _PI
    angle %= _TWO_PI
    angle -= _PI
    return angle


# -- state ------------------------------------------------------------------------------------
def advance_odometry(
    before: np.ndarray,
    after: np.ndarray,
    estimate: np.ndarray,
    certainty: np.ndarray,
    noise: np.ndarray,
    pe: float,
    rotation_noise: float,
    distance_noise: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One control step of every robot's odometry (eq. 2): the true displacements ``dx, dy`` (K, n), the new
    estimates (K, n, 3) and certainties (K, n).

    ``before``/``after``: true poses (K, n, 3); ``estimate`` and ``certainty``: before the step (not
    written); ``noise`` (K, 2, n): each copy's draw, turn noise first.
    """
    x0, y0, th0 = before[..., 0], before[..., 1], before[..., 2]
    dx, dy = after[..., 0] - x0, after[..., 1] - y0
    c, s = libm(math.cos, th0), libm(math.sin, th0)
    eth = estimate[..., 2]
    ce, se = libm(math.cos, eth), libm(math.sin, eth)
    turn = wrap_angle(after[..., 2] - th0)
    forward, lateral = dx * c + dy * s, dy * c - dx * s
    moved = ((forward != 0.0) | (lateral != 0.0)).astype(float)
    scale = distance_noise * noise[:, 1] * moved + 1.0
    size = np.abs(turn)
    heading = eth + turn + rotation_noise * size * noise[:, 0]
    out = np.empty_like(estimate)
    out[..., 0] = estimate[..., 0] + (forward * ce - lateral * se) * scale
    out[..., 1] = estimate[..., 1] + (lateral * ce + forward * se) * scale
    out[..., 2] = wrap_angle(heading)
    return dx, dy, out, certainty * libm(functools.partial(pow, pe), size)


class CopyView(NamedTuple):
    """Every robot's true offsets and distances to the points ``[targets, robots, landmarks]`` of its copy (K, n, P)."""

    rel_x: np.ndarray
    rel_y: np.ndarray
    distance: np.ndarray


def view_geometry(targets: np.ndarray, pose: np.ndarray, landmarks: np.ndarray) -> CopyView:
    """:meth:`Cameras.look` of every copy: ``targets`` (K, T, 2), true ``pose`` (K, n, 3), ``landmarks`` (L, 2)."""
    k = len(pose)
    points = np.concatenate([targets, pose[..., :2], np.broadcast_to(landmarks, (k, *landmarks.shape))], axis=1)
    rel = points[:, None, :, :] - pose[:, :, None, :2]
    rel_x, rel_y = rel[..., 0], rel[..., 1]
    return CopyView(rel_x, rel_y, np.hypot(rel_x, rel_y))


def presence(
    gaps: np.ndarray, target_live: np.ndarray, at: np.ndarray, timer: np.ndarray, reach: float, persist: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``Foraging._update_presence`` of every copy: the new ``at``, ``timer`` and nearest live target distance (K, n).

    ``gaps``: robot-to-target distances (K, n, T); ``at``/``timer``: before (not written).
    """
    live_any = target_live.any(axis=1)
    masked = np.where(target_live[:, None, :], gaps, np.inf)
    nearest_j = masked.argmin(axis=2)  # the first nearest live target, as the lone env picks it
    nearest = np.take_along_axis(gaps, nearest_j[..., None], axis=2)[..., 0]
    new_at = np.where(live_any[:, None] & (nearest <= reach), nearest_j, -1)
    nearest_live = np.where(live_any[:, None], nearest, 0.0)
    if persist:  # a consumed target still holds a robot
        some_gone = ~target_live.all(axis=1)
        if some_gone.any():
            any_j = gaps.argmin(axis=2)
            any_d = np.take_along_axis(gaps, any_j[..., None], axis=2)[..., 0]
            new_at = np.where(some_gone[:, None], np.where(any_d <= reach, any_j, -1), new_at)
    new_timer = np.where((new_at >= 0) & (new_at == at), timer, 0.0)
    return new_at, new_timer, nearest_live


# -- sensing ----------------------------------------------------------------------------------
class Sensed(NamedTuple):
    """What :func:`perceive_copies` found: the new estimates and certainties, counts and whether a target was seen."""

    estimate: np.ndarray  #: (K, n, 3)
    certainty: np.ndarray  #: (K, n)
    count: np.ndarray  #: (K, n) detections per robot
    any_target: np.ndarray  #: (K,) bool


def perceive_copies(
    view: CopyView,
    pose: np.ndarray,
    visible: np.ndarray,
    estimate: np.ndarray,
    certainty: np.ndarray,
    rngs: Sequence[np.random.Generator],
    vision: VisionModel,
    robot_radius: float,
    clear_distance: float,
    grid: GridSpec,
    table: np.ndarray,
) -> Sensed:
    """:func:`~teamgym.envs.foraging.sensing.perceive` of every copy, every robot live; writes ``table`` (K, n, 1 + D, 8).

    ``visible`` (K, T): targets the cameras can see; ``estimate``/``certainty``: the odometry
    after this step's advance (not written); ``rngs``: each copy's generator.
    """
    k_copies, n, p = view.distance.shape
    t = visible.shape[1]
    reach, half = vision.camera_range, 0.5 * vision.camera_fov
    candidate = view.distance <= reach
    robots = np.arange(n)
    candidate[:, robots, t + robots] = False  # a camera does not see its own robot
    candidate[:, :, :t] &= visible[:, None, :]
    kk, ii, jj = np.nonzero(candidate)  # row-major: per copy, per robot, by point
    distance = view.distance[kk, ii, jj]
    rel_x, rel_y = view.rel_x[kk, ii, jj], view.rel_y[kk, ii, jj]
    bearing = wrap_angle(libm(math.atan2, rel_y, rel_x) - pose[kk, ii, 2])
    keep = np.abs(bearing) <= half
    if n > 1 and len(kk):
        teammates = view.distance[:, :, t : t + n] + np.where(np.eye(n, dtype=bool), np.inf, 0.0)
        crowded = (teammates < clear_distance).any(axis=(1, 2))
        check = keep & crowded[kk]
        if check.any():
            seen = (kk[check], ii[check], jj[check], rel_x[check], rel_y[check], distance[check])
            hidden = _occluded(pose, *seen, t, robot_radius)
            keep[check] = ~hidden
    kk, ii, jj, distance, bearing = kk[keep], ii[keep], jj[keep], distance[keep], bearing[keep]
    pv = _PV[
        np.minimum((distance / vision.camera_range * 4).astype(np.int64), 3),
        np.minimum((np.abs(bearing) / half * 3).astype(np.int64), 2),
    ]
    landmark = jj >= t + n
    fixes = _landmark_fixes(kk[landmark], ii[landmark], distance[landmark], pv[landmark], certainty, n)
    obj = ~landmark
    ok, oi, oj, od, ob, opv = kk[obj], ii[obj], jj[obj], distance[obj], bearing[obj], pv[obj]
    fk, fi = kk[landmark][fixes], ii[landmark][fixes]
    fd, fb, fpv = distance[landmark][fixes], bearing[landmark][fixes], pv[landmark][fixes]
    md, mb, fmd, fmb = _measure(vision, rngs, ok, od, ob, opv, fk, fd, fb, fpv, k_copies)
    estimate, certainty = estimate.copy(), certainty.copy()
    if len(fk):  # re-localise at the landmark: the truth plus the measurement error, Pl = Pv
        x, y, theta = pose[fk, fi, 0], pose[fk, fi, 1], pose[fk, fi, 2]
        ray, measured_ray = theta + fb, theta + fmb
        estimate[fk, fi, 0] = x + (fd * libm(math.cos, ray) - fmd * libm(math.cos, measured_ray))
        estimate[fk, fi, 1] = y + (fd * libm(math.sin, ray) - fmd * libm(math.sin, measured_ray))
        estimate[fk, fi, 2] = wrap_angle(theta + (fb - fmb))
        certainty[fk, fi] = fpv
    table[..., :] = 0.0
    table[..., 6:8] = NO_CELL
    table[:, :, 0, 0] = SENDER
    table[:, :, 0, 1:3] = cells_of(grid, estimate[..., :2])
    table[:, :, 0, 3] = certainty
    group = ok * n + oi
    count = np.bincount(group, minlength=k_copies * n).reshape(k_copies, n)
    if len(ok):
        first = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
        slot = np.arange(len(group)) - np.repeat(first, np.diff(np.r_[first, len(group)])) + 1
        ex, ey, eth = estimate[ok, oi, 0], estimate[ok, oi, 1], estimate[ok, oi, 2]
        heading = eth + mb
        seen = np.stack([libm(math.cos, heading) * md + ex, libm(math.sin, heading) * md + ey], axis=-1)
        gx, gy = cells_of(grid, seen).T
        robot = oj >= t
        rows = np.empty((len(ok), 8))
        rows[:, 0] = np.where(robot, float(ROBOT), float(TARGET))
        rows[:, 1], rows[:, 2] = gx, gy
        rows[:, 3] = opv * certainty[ok, oi]
        rows[:, 4], rows[:, 5] = md, mb
        rows[:, 6] = np.where(robot, NO_CELL, gx)
        rows[:, 7] = np.where(robot, NO_CELL, gy)
        table[ok, oi, slot] = rows
    any_target = np.zeros(k_copies, dtype=bool)
    any_target[ok[oj < t]] = True
    return Sensed(estimate, certainty, count, any_target)


def _occluded(
    pose: np.ndarray,
    kk: np.ndarray,
    ii: np.ndarray,
    jj: np.ndarray,
    rel_x: np.ndarray,
    rel_y: np.ndarray,
    distance: np.ndarray,
    t: int,
    radius: float,
) -> np.ndarray:
    """Whether a teammate hides each sighting (``Cameras._unoccluded_xy``'s operations, every teammate at once)."""
    n = pose.shape[1]
    x, y = pose[kk, ii, 0], pose[kk, ii, 1]
    ox = pose[kk, :, 0] - x[:, None]  # (S, n): every robot of the copy from the viewer
    oy = pose[kk, :, 1] - y[:, None]
    safe = np.maximum(distance, 1e-12)
    ux, uy = rel_x / safe, rel_y / safe
    along = ux[:, None] * ox + uy[:, None] * oy
    blocks = (along > 0) & (along < (distance - radius)[:, None]) & ((ox * ox + oy * oy) - along * along < radius**2)
    others = np.arange(n)
    blocks &= others[None, :] != ii[:, None]  # a robot does not hide its own view
    blocks &= (t + others)[None, :] != jj[:, None]  # nor a teammate itself
    return blocks.any(axis=1)


def _landmark_fixes(
    kk: np.ndarray, ii: np.ndarray, distance: np.ndarray, pv: np.ndarray, certainty: np.ndarray, n: int
) -> np.ndarray:
    """Indices (into the landmark sightings) of the re-localising ones: each robot's nearest landmark in view
    (the first of the nearest, in landmark order) whose Pv is at least the robot's Pl (``landmark_fixes``)."""
    if not len(kk):
        return np.zeros(0, dtype=np.int64)
    group = kk * n + ii
    order = np.lexsort((distance, group))  # stable: by robot, then distance, then landmark order
    sorted_group = group[order]
    first = order[np.r_[True, sorted_group[1:] != sorted_group[:-1]]]
    return first[pv[first] >= certainty[kk[first], ii[first]]]


def _measure(
    vision: VisionModel,
    rngs: Sequence[np.random.Generator],
    ok: np.ndarray,
    od: np.ndarray,
    ob: np.ndarray,
    opv: np.ndarray,
    fk: np.ndarray,
    fd: np.ndarray,
    fb: np.ndarray,
    fpv: np.ndarray,
    k_copies: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Measured distances and bearings of the object sightings and of the fixes (``measure_all``, copy by copy draws)."""
    if vision.noise == 0.0 or not len(ok) + len(fk):
        return od, ob, fd, fb
    objects, fixes = np.bincount(ok, minlength=k_copies).tolist(), np.bincount(fk, minlength=k_copies).tolist()
    object_noise, fix_noise = [], []
    for rng, m, r in zip(rngs, objects, fixes):
        if m + r:
            z = rng.standard_normal(2 * (m + r))
            object_noise.append(z[: 2 * m].reshape(2, m))
            fix_noise.append(z[2 * m :].reshape(r, 2))
    object_z = np.concatenate(object_noise, axis=1)
    fix_z = np.concatenate(fix_noise)
    md, mb = _measured(vision, od, ob, opv, object_z[0], object_z[1])
    fmd, fmb = _measured(vision, fd, fb, fpv, fix_z[:, 0], fix_z[:, 1])
    return md, mb, fmd, fmb


def _measured(
    vision: VisionModel, d: np.ndarray, b: np.ndarray, pv: np.ndarray, d_noise: np.ndarray, b_noise: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`VisionModel.measure_one` of every sighting."""
    spread = vision.noise * (1.0 - pv)
    measured = np.minimum(np.maximum(0.0, d + DISTANCE_ERROR * spread * d_noise), vision.max_distance)
    turned = b + BEARING_ERROR * spread * b_noise
    beyond = np.abs(turned) > _PI
    if beyond.any():
        turned[beyond] = (turned[beyond] + _PI) % _TWO_PI - _PI
    return measured, turned


# -- control ----------------------------------------------------------------------------------
def goto_copies(
    controller: GoToController,
    cells: np.ndarray,
    pose: np.ndarray,
    estimate: np.ndarray,
    at: np.ndarray,
    timer: np.ndarray,
    table: np.ndarray,
    any_target: np.ndarray,
    cell_xy: np.ndarray,
    cell_centre: np.ndarray,
    field_size: tuple[float, float],
    held_done: float | None,
) -> np.ndarray:
    """``(v, ω)`` of every robot of every copy for its go-to cell ``cells`` (K, n): ``Foraging.goto_commands``.

    ``table``: the copies' sightings tables (K, n, 1 + D, 8); ``any_target`` (K,): whether a
    copy's last sensing phase saw a target (else no robot homes); ``held_done``: with ``persist``
    consumption, the time after which a robot at a target is no longer held, else ``None``.
    """
    goal = cell_xy[cells].astype(float)  # (K, n, 2) cell coordinates of each go-to cell
    # Homing: the detected target nearest (in cells) to the go-to cell, if within one cell of it.
    home_d = np.full(cells.shape, np.nan)
    home_b = np.full(cells.shape, np.nan)
    if any_target.any():
        detections = table[:, :, 1:, 4:8].astype(float)  # (K, n, D, 4): measured d, b, target cell x, y
        gap = np.maximum(np.abs(detections[..., 2] - goal[..., 0, None]), np.abs(detections[..., 3] - goal[..., 1, None]))
        best = gap.argmin(axis=2)[..., None]
        homes = (np.take_along_axis(gap, best, axis=2)[..., 0] <= 1) & any_target[:, None]
        home_d = np.where(homes, np.take_along_axis(detections[..., 0], best, axis=2)[..., 0], np.nan)
        home_b = np.where(homes, np.take_along_axis(detections[..., 1], best, axis=2)[..., 0], np.nan)
    # Stop at a target when the go-to cell is within one cell of the robot's estimated (last packet's) cell.
    present = at >= 0
    if held_done is not None:
        present &= ~(timer >= held_done)
    own = table[:, :, 0, 1:3].astype(float)
    stop = present & (np.maximum(np.abs(own[..., 0] - goal[..., 0]), np.abs(own[..., 1] - goal[..., 1])) <= 1)
    aim = cell_centre[cells]
    return _commands(controller, estimate, pose, aim, home_d, home_b, stop, field_size)


def _commands(
    controller: GoToController,
    estimate: np.ndarray,
    pose: np.ndarray,
    aim: np.ndarray,
    home_d: np.ndarray,
    home_b: np.ndarray,
    stop: np.ndarray,
    field_size: tuple[float, float],
) -> np.ndarray:
    """:meth:`GoToController.command_pairs` of every robot of every copy: ``(v, ω)`` (K, n, 2)."""
    goal_x, goal_y = aim[..., 0] - estimate[..., 0], aim[..., 1] - estimate[..., 1]
    distance = np.hypot(goal_x, goal_y)
    bearing = libm(math.atan2, goal_y, goal_x) - estimate[..., 2]
    homes = home_d == home_d  # not NaN
    distance = np.where(homes, home_d, distance)
    bearing = np.where(homes, home_b, bearing)
    c, s = libm(math.cos, pose[..., 2]), libm(math.sin, pose[..., 2])
    push_x, push_y = _pushes(controller, pose, field_size, c, s)
    error = libm(math.atan2, push_y + libm(math.sin, bearing), push_x + libm(math.cos, bearing))
    top, gain = controller.max_turn_rate, controller.turn_gain
    v = controller.max_speed * np.maximum(0.0, libm(math.cos, error)) * np.minimum(1.0, distance / controller.slow_distance)
    omega = np.minimum(np.maximum(gain * error, -top), top)
    halt = stop | ((distance < controller.arrive_distance) & ~homes)
    out = np.empty((*distance.shape, 2))
    out[..., 0] = np.where(halt, 0.0, v)
    out[..., 1] = np.where(halt, 0.0, omega)
    return out


def _pushes(
    controller: GoToController, pose: np.ndarray, field_size: tuple[float, float], c: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``GoToController._pushes`` of every robot (K, n): away from near teammates (summed in index order) and walls."""
    k_copies, n = pose.shape[:2]
    push_x, push_y = np.zeros((k_copies, n)), np.zeros((k_copies, n))
    if n > 1:
        rel = pose[:, None, :, :2] - pose[:, :, None, :2]  # [k, i, j]: robot j seen from robot i
        gap = np.hypot(rel[..., 0], rel[..., 1])
        avoid = controller.avoid_range
        near = gap < avoid
        near[:, np.arange(n), np.arange(n)] = False
        if near.any():
            scale, gain = avoid - 2 * controller.robot_radius + 1e-9, controller.avoid_gain
            strength, length = (avoid - gap) / scale, np.maximum(gap, 1e-9)
            term_x, term_y = strength * (rel[..., 0] / length), strength * (rel[..., 1] / length)
            sum_x, sum_y = np.zeros((k_copies, n)), np.zeros((k_copies, n))
            for j in range(n):  # Σ_j in index order, as the lone controller adds them
                sum_x = np.where(near[:, :, j], sum_x + term_x[:, :, j], sum_x)
                sum_y = np.where(near[:, :, j], sum_y + term_y[:, :, j], sum_y)
            wx, wy = -sum_x * gain * 2, -sum_y * gain * 2
            pushed = near.any(axis=2)
            push_x = np.where(pushed, push_x + (wx * c + wy * s), push_x)
            push_y = np.where(pushed, push_y + (wy * c - wx * s), push_y)
    width, height = field_size
    radius, reach, gain = controller.robot_radius, controller.wall_range, controller.avoid_gain
    x, y = pose[..., 0], pose[..., 1]
    wx = np.maximum((reach - (x - radius)) / reach, 0.0) * gain - np.maximum((reach - (width - x - radius)) / reach, 0.0) * gain
    wy = np.maximum((reach - (y - radius)) / reach, 0.0) * gain - np.maximum((reach - (height - y - radius)) / reach, 0.0) * gain
    return push_x + (wx * c + wy * s), push_y + (wy * c - wx * s)
