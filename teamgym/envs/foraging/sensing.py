"""The sensing phase of ``Foraging-v0`` over all robots at once: cameras, re-localisation, perception tuples.

:class:`Cameras` holds what every robot's camera needs besides the poses: the landmarks and
the occlusion masks, built once per number of live targets. :meth:`Cameras.view` computes
the geometry of every robot to every point ``[targets, robots, landmarks]`` once per control
step (the state phase reads the target distances from it); :meth:`Cameras.seen` applies
:func:`~teamgym.envs.foraging.perception.visibility`'s rules to the live points.
:func:`perceive` runs the phase: sightings, their measurement errors, re-localisation at
landmarks (:func:`relocalise`) and the perception tuples of section 2.1 (eq. 1) in one
:class:`Sightings` table, from which every robot's packet is a slice.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.perception import ROBOT, SENDER, TARGET, Odometry, VisionModel, in_view, occluded

assert (TARGET, ROBOT) == (0, 1)  # a detection's class is written as "is a robot"

__all__ = [
    "NO_CELL",
    "SEEN_LANDMARK",
    "SEEN_ROBOT",
    "SEEN_TARGET",
    "Cameras",
    "Geometry",
    "Sightings",
    "View",
    "cells_of",
    "landmark_fixes",
    "measure_all",
    "perceive",
    "relocalise",
]

#: Cell coordinate of the rows of :attr:`Sightings.table` that are not target detections (far from every cell).
NO_CELL = 1.0e6
#: Above this many (sighting, teammate) pairs :meth:`Cameras.seen` checks occlusion in one numpy pass, below it one by one.
_SCALAR_CHECKS = 64
#: Up to this many (robot, point) pairs :meth:`Cameras.sightings` reads distances and bearings from lists.
_LIST_GATHER = 512
#: Columns of :attr:`Sightings.table`: the tuple, the measured polar position, the target cell.
TUPLE, POLAR, TARGET_CELL = slice(0, 4), slice(4, 6), slice(6, 8)


class Sightings(NamedTuple):
    """What the robots perceive in one sensing phase (rows: robots in ``possible_agents`` order).

    ``table`` (n, 1 + D, 8) float32: per robot, row 0 is its own tuple ``(SENDER, gx, gy, Pl)``
    and rows 1.. its detections, targets first, then zero padding; columns :data:`TUPLE`
    ``(class, gx, gy, Pc)``, :data:`POLAR` (measured distance and bearing) and
    :data:`TARGET_CELL` (``(gx, gy)`` of a target detection, :data:`NO_CELL` on other rows).
    """

    table: np.ndarray
    count: np.ndarray  #: (n,) int: detections per robot
    any_target: bool  #: whether any robot detects a target

    @property
    def detections(self) -> np.ndarray:
        """(n, D, 4) float32 (a view): the tuples ``(class, gx, gy, Pc)``."""
        return self.table[:, 1:, TUPLE]

    @property
    def polar(self) -> np.ndarray:
        """(n, D, 2) float32 (a view): measured distance (m) and bearing (rad) of each detection."""
        return self.table[:, 1:, POLAR]

    def packet(self, i: int) -> np.ndarray:
        """Robot i's packet payload: its own tuple and its detections, flat float32 (a new array, never a view of the
        table: the table is the copy's row, rewritten at the next sensing phase, and packets may stay in flight)."""
        return np.array(self.table[i, : 1 + self.count[i], TUPLE]).reshape(-1)


class View(NamedTuple):
    """Every robot's true geometry to the points ``[targets, robots, landmarks]`` (:func:`in_view`)."""

    rel: np.ndarray  #: (n, P, 2) offsets (m)
    distance: np.ndarray  #: (n, P) m
    bearing: np.ndarray  #: (n, P) rad, in [−π, π)
    in_sector: np.ndarray  #: (n, P) bool: within the camera's range and opening


class Geometry(NamedTuple):
    """:class:`View`'s offsets and distances as lists (per robot, per point ``[targets, robots, landmarks]``).

    What the env keeps between phases (:meth:`Cameras.look`): the state phase reads the target
    distances, the go-to controller the teammates' offsets, the sensing phase all of them;
    bearings are computed only for the points within the camera's range (:meth:`Cameras.sight`).
    """

    distance: list[list[float]]  #: (n, P) m
    rel_x: list[list[float]]  #: (n, P) x offsets (m)
    rel_y: list[list[float]]  #: (n, P) y offsets (m)
    n_targets: int  #: T: the target columns come first


#: A sighting of :meth:`Cameras.sight`: robot row, kind (:data:`SEEN_TARGET`, :data:`SEEN_ROBOT`,
#: :data:`SEEN_LANDMARK`), true distance (m) and bearing (rad).
Sighting = tuple[int, int, float, float]
SEEN_TARGET, SEEN_ROBOT, SEEN_LANDMARK = 0, 1, 2


def cells_of(grid: GridSpec, xy: np.ndarray) -> np.ndarray:
    """:meth:`GridSpec.cell_of` as floats (the same cells): ``(..., 2)`` positions to ``(gx, gy)``."""
    cells = xy / grid.cell_size
    cells += 1e-9
    np.floor(cells, out=cells)
    np.maximum(cells, 0.0, out=cells)
    return np.minimum(cells, (grid.nx - 1, grid.ny - 1), out=cells)


class Cameras:
    """Every robot's forward camera: which targets, teammates and landmarks it sees (see the module docstring)."""

    def __init__(self, n_robots: int, landmarks: np.ndarray, camera_range: float, camera_fov: float, robot_radius: float):
        self.n = int(n_robots)
        self.landmarks = np.asarray(landmarks, dtype=float).reshape(-1, 2)
        self.camera_range, self.camera_fov, self.radius = float(camera_range), float(camera_fov), float(robot_radius)
        # Teammates at least this far apart hide nothing from each other (see ``seen``): the camera's range,
        # or 0 when it does not reach past a robot's radius (nothing is hidden then), inf in between (always look).
        r, reach = self.radius, self.camera_range
        self.clear_distance = reach if reach > r + 1e-6 else (0.0 if reach <= r else math.inf)
        self._self_gap = np.where(np.eye(self.n, dtype=bool), np.inf, 0.0)  # added to the teammate distances
        self._masks: dict[tuple[int, ...], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._blank: np.ndarray | None = None

    def points(self, targets: np.ndarray) -> np.ndarray:
        """A buffer of the points ``[targets, robots, landmarks]`` (P, 2); :meth:`view` fills the robots' rows."""
        return np.concatenate([targets, np.zeros((self.n, 2)), self.landmarks])

    def view(self, pose: np.ndarray, points: np.ndarray) -> View:
        """The geometry of every robot (true ``pose`` (n, 3)) to ``points`` (the buffer of :meth:`points`)."""
        t = len(points) - self.n - len(self.landmarks)
        points[t : t + self.n] = pose[:, :2]
        return View(*in_view(pose, points, self.camera_range, self.camera_fov))

    def look(self, pose: np.ndarray, points: np.ndarray) -> Geometry:
        """:meth:`view` without bearings and sectors, as lists: the offsets and distances (one numpy pass, the same bits)."""
        t = len(points) - self.n - len(self.landmarks)
        points[t : t + self.n] = pose[:, :2]
        rel = points[None, :, :] - pose[:, None, :2]
        rel_x, rel_y = rel[..., 0], rel[..., 1]
        return Geometry(np.hypot(rel_x, rel_y).tolist(), rel_x.tolist(), rel_y.tolist(), t)

    def sight(self, pose: list[list[float]], geometry: Geometry, visible: list[bool]) -> list[Sighting]:
        """What every camera sees, row-major (per robot, by point ``[targets, robots, landmarks]``): :meth:`sightings`
        in scalar float arithmetic (the same IEEE operations: ``math.atan2`` is libm's, as numpy's) from :meth:`look`.

        ``pose``: true ``(x, y, θ)`` per robot; ``visible[j]``: whether target j can be seen (live, or ``persist``).
        Bearings are computed only for the points within range; occlusion by teammates as :meth:`_unoccluded`.
        """
        reach, half, t, n = self.camera_range, 0.5 * self.camera_fov, geometry.n_targets, self.n
        pi, two_pi, atan2 = math.pi, 2 * math.pi, math.atan2
        found: list[Sighting] = []
        offsets: list[tuple[float, float]] = []
        for i, (drow, xrow, yrow) in enumerate(zip(geometry.distance, geometry.rel_x, geometry.rel_y)):
            theta, me = pose[i][2], t + i
            for j, d in enumerate(drow):
                if d <= reach and j != me and (j >= t or visible[j]):
                    b = (atan2(yrow[j], xrow[j]) - theta + pi) % two_pi - pi
                    if abs(b) <= half:
                        found.append((i, SEEN_TARGET if j < t else SEEN_ROBOT if j < t + n else SEEN_LANDMARK, d, b))
                        offsets.append((xrow[j], yrow[j], j))
        if n > 1 and found:
            clear = self.clear_distance
            if any(g < clear for i, drow in enumerate(geometry.distance) for k, g in enumerate(drow[t : t + n]) if k != i):
                xy = [(x, y) for x, y, _ in pose]
                rows, cols, lengths = [f[0] for f in found], [o[2] for o in offsets], [f[2] for f in found]
                keep = self._unoccluded_xy(xy, [o[:2] for o in offsets], rows, cols, lengths, t)
                found = [f for f, kept in zip(found, keep) if kept]
        return found

    def _masks_for(self, live: tuple[int, ...], n_targets: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For the ``live`` targets: columns of a :class:`View` to keep, (n, P) points a robot may see
        (not itself) and (n, P, n) occluders that count, P = live targets + robots + landmarks."""
        if live not in self._masks:
            n, t = self.n, len(live)
            columns = np.concatenate([np.array(live, dtype=np.int64), n_targets + np.arange(n + len(self.landmarks))])
            not_self = np.ones((n, len(columns)), dtype=bool)
            not_self[np.arange(n), t + np.arange(n)] = False
            counted = np.ones((n, len(columns), n), dtype=bool)
            counted[np.arange(n), :, np.arange(n)] = False  # a robot does not hide its own view
            counted[:, t + np.arange(n), np.arange(n)] = False  # nor a teammate itself
            self._masks[live] = (columns, not_self, counted)
        return self._masks[live]

    def seen(self, pose: np.ndarray, view: View, live: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Seen (n, P) bool, true distances and bearings (n, P) of the points ``[live targets, robots, landmarks]``.

        ``view``: :meth:`view` at ``pose`` over every target; ``live``: indices of the live targets.
        """
        rows, cols, _, _, distance, bearing = self._visible(pose, view, live)
        seen = np.zeros(distance.shape, dtype=bool)
        seen[rows, cols] = True
        return seen, distance, bearing

    def sightings(self, pose: np.ndarray, view: View, live: np.ndarray) -> tuple[list[int], list[int], list[float], list[float]]:
        """:meth:`seen` as lists, row-major (per robot, by point): robot rows, point columns, true distances, bearings."""
        return self._visible(pose, view, live)[:4]

    def _visible(self, pose: np.ndarray, view: View, live: np.ndarray) -> tuple[Any, ...]:
        """Rows, columns, distances and bearings (lists) of the visible points, then the (n, P) distances and bearings."""
        n_targets = len(view.distance[0]) - self.n - len(self.landmarks)
        columns, not_self, counted = self._masks_for(tuple(live.tolist()), n_targets)
        rel, distance, bearing, seen = view
        if len(live) < n_targets:
            rel, distance, bearing, seen = rel[:, columns], distance[:, columns], bearing[:, columns], seen[:, columns]
        seen = seen & not_self
        rows, cols = np.nonzero(seen)
        t = len(live)
        # A teammate hides a point only if it is nearer than the camera's range (the point lies within it and
        # the teammate within a radius of the sight line): skipped when every teammate is farther.
        hidden = self.n > 1 and len(rows) and np.count_nonzero(distance[:, t : t + self.n] + self._self_gap < self.clear_distance)
        if hidden and len(rows) * self.n > _SCALAR_CHECKS:
            seen &= ~occluded(pose, rel, distance, pose[:, :2], self.radius, counted)
            rows, cols = np.nonzero(seen)
            hidden = False
        rows, cols = rows.tolist(), cols.tolist()
        if distance.size <= _LIST_GATHER:  # a few values: read them from lists (the same floats) instead of fancy indexing
            d, b = distance.tolist(), bearing.tolist()
            found = rows, cols, [d[i][j] for i, j in zip(rows, cols)], [b[i][j] for i, j in zip(rows, cols)]
        else:
            found = rows, cols, distance[rows, cols].tolist(), bearing[rows, cols].tolist()
        if hidden:
            keep = self._unoccluded(pose, [rel[i, j].tolist() for i, j in zip(rows, cols)], *found, t)
            found = tuple([v for v, kept in zip(values, keep) if kept] for values in found)
        return (*found, distance, bearing)

    def _unoccluded(
        self,
        pose: np.ndarray,
        offsets: list[list[float]],
        rows: list[int],
        cols: list[int],
        lengths: list[float],
        bearings: list[float],
        t: int,
    ) -> list[bool]:
        """:func:`~teamgym.envs.foraging.perception.occluded` for the few sightings ``(rows[k], cols[k])``, one by one
        (the same float operations): whether no teammate hides each (``t``: the robots' first column)."""
        return self._unoccluded_xy(pose[:, :2].tolist(), offsets, rows, cols, lengths, t)

    def _unoccluded_xy(
        self,
        xy: list[tuple[float, float]],
        offsets: list[tuple[float, float]],
        rows: list[int],
        cols: list[int],
        lengths: list[float],
        t: int,
    ) -> list[bool]:
        """:meth:`_unoccluded` with the robots' positions ``xy`` as a list."""
        radius = self.radius
        reach = radius**2
        keep = []
        for i, j, (rx, ry), d in zip(rows, cols, offsets, lengths):
            x, y = xy[i]
            safe = max(d, 1e-12)
            ux, uy = rx / safe, ry / safe
            clear = True
            for k, (kx, ky) in enumerate(xy):
                if k == i or j == t + k:  # a robot does not hide its own view, nor a teammate itself
                    continue
                ox, oy = kx - x, ky - y
                along = ux * ox + uy * oy
                if along > 0 and along < d - radius and (ox * ox + oy * oy) - along * along < reach:
                    clear = False
                    break
            keep.append(clear)
        return keep

    def blank(self, n_slots: int, out: np.ndarray | None = None) -> np.ndarray:
        """An empty :attr:`Sightings.table`: zeros, :data:`NO_CELL` in the target-cell columns (a new array, or ``out`` reset)."""
        if self._blank is None or self._blank.shape[1] != 1 + n_slots:
            self._blank = np.zeros((self.n, 1 + n_slots, 8), dtype=np.float32)
            self._blank[:, :, TARGET_CELL] = NO_CELL
        if out is None:
            return self._blank.copy()
        out[...] = self._blank
        return out


def landmark_fixes(
    certainty: list[float],
    sighted: Sequence[tuple[int, int, float, float]],
    pv_of: Callable[[float, float], float],
    live: list[bool],
) -> list[tuple[int, float, float, float]]:
    """The ``live`` robots whose nearest landmark in view re-localises them (its Pv ≥ Pl).

    ``sighted``: the landmark sightings ``(robot row, landmark, true distance, bearing)``, row-major.
    Returns, in robot order, each one's row and that landmark's true distance, bearing and Pv
    (``pv_of(distance, bearing)``); empty if none. The nearest is the first of the nearest in
    landmark order (as ``np.argmin``).
    """
    nearest: dict[int, tuple[float, float]] = {}
    for i, _, d, b in sighted:
        if live[i] and (i not in nearest or d < nearest[i][0]):
            nearest[i] = (d, b)
    fixes = []
    for i, (d, b) in nearest.items():
        pv = pv_of(d, b)
        if pv >= certainty[i]:
            fixes.append((i, d, b, pv))
    return fixes


def relocalise(
    odometry: Odometry,
    pose: np.ndarray | list[list[float]],
    fixes: list[tuple[int, float, float, float]],
    measured_d: list[float],
    measured_b: list[float],
) -> None:
    """Re-localise the robots of :func:`landmark_fixes` from their landmark's measured distance and bearing.

    The estimate becomes the truth plus the measurement error (the pose implied by the measured
    landmark) and Pl that sighting's Pv (:meth:`Odometry.relocalise`).
    """
    estimate, certainty, pi, two_pi = odometry.estimate, odometry.certainty, math.pi, 2 * math.pi
    for (i, true_d, true_b, pv), m_d, m_b in zip(fixes, measured_d, measured_b):
        x, y, theta = (float(v) for v in pose[i])
        ray, measured_ray = theta + true_b, theta + m_b
        estimate[i] = (
            x + (true_d * math.cos(ray) - m_d * math.cos(measured_ray)),
            y + (true_d * math.sin(ray) - m_d * math.sin(measured_ray)),
            (theta + (true_b - m_b) + pi) % two_pi - pi,
        )
        certainty[i] = pv


def measure_all(
    vision: VisionModel,
    sightings: tuple[Sequence[float], Sequence[float], Sequence[float]],
    fixes: list[tuple[int, float, float, float]],
    rng: np.random.Generator,
) -> tuple[tuple[list[float], list[float]], tuple[list[float], list[float]]]:
    """Measured (distance, bearing) of the object sightings (true distances, bearings, Pv) and of the landmark fixes.

    One draw serves both, in the order of the paper's model run robot by robot: the distance
    errors of every object sighting, then their bearing errors, then each re-localising
    robot's distance and bearing error (:meth:`VisionModel.measure_one` per value).
    """
    d, b, pv = (list(values) for values in sightings)
    m, r = len(d), len(fixes)
    if vision.noise == 0.0 or not m + r:
        return (d, b), ([f[1] for f in fixes], [f[2] for f in fixes])
    noise = rng.standard_normal(2 * (m + r)).tolist()
    measure = vision.measure_one
    objects = [measure(*values) for values in zip(d, b, pv, noise[:m], noise[m : 2 * m])]
    fixed = [measure(f[1], f[2], f[3], noise[2 * m + 2 * k], noise[2 * m + 2 * k + 1]) for k, f in enumerate(fixes)]
    return ([v[0] for v in objects], [v[1] for v in objects]), ([v[0] for v in fixed], [v[1] for v in fixed])


def _cell(value: float, cell_size: float, top: int) -> float:
    """:func:`cells_of` of one coordinate (the same float operations)."""
    return float(min(max(math.floor(value / cell_size + 1e-9), 0), top))


def perceive(
    cameras: Cameras,
    grid: GridSpec,
    vision: VisionModel,
    odometry: Odometry,
    pose: list[list[float]],
    geometry: Geometry,
    visible: list[bool],
    live: list[bool],
    n_slots: int,
    rng: np.random.Generator,
    out: np.ndarray | None = None,
) -> Sightings:
    """One sensing phase: the sightings of every robot (see the module docstring).

    ``pose``: the true poses (rows ``x, y, θ``); ``geometry``: :meth:`Cameras.look` at them;
    ``visible[j]``: whether target j can be seen; ``live[i]``: robot i is in the episode (only
    they re-localise). Random draws, in order: the measurement errors of every target and
    teammate sighting (row-major: per robot, targets before robots), then the
    re-localisations' (:func:`measure_all`). A tuple's position and Pc use the odometry after
    the re-localisation. ``out``: the table to write (n, 1 + ``n_slots``, 8) float32, a new one if None.

    Distances are one numpy pass over every robot and point (:meth:`Cameras.look`); the few
    sightings that follow are handled one by one in scalar float arithmetic (the same IEEE
    operations as an array form).
    """
    n = len(pose)
    seen = cameras.sight(pose, geometry, visible)
    objects = [s for s in seen if s[1] != SEEN_LANDMARK]  # row-major: per robot, targets before robots
    pv_of = vision.pv_of
    sighted_d, sighted_b = [s[2] for s in objects], [s[3] for s in objects]
    sighted_pv = [pv_of(d, b) for d, b in zip(sighted_d, sighted_b)]
    landmarks = [s for s in seen if s[1] == SEEN_LANDMARK]
    fixes = landmark_fixes(odometry.certainty.tolist(), landmarks, pv_of, live) if landmarks else []
    (measured_d, measured_b), fixed = measure_all(vision, (sighted_d, sighted_b, sighted_pv), fixes, rng)
    if fixes:
        relocalise(odometry, pose, fixes, *fixed)
    est, certainty = odometry.estimate.tolist(), odometry.certainty.tolist()
    size, (top_x, top_y) = grid.cell_size, (grid.nx - 1, grid.ny - 1)
    table = cameras.blank(n_slots, out)
    table[:, 0, :4] = [(SENDER, _cell(x, size, top_x), _cell(y, size, top_y), pl) for (x, y, _), pl in zip(est, certainty)]
    count = [0] * n
    any_target = False
    if objects:
        cos, sin = math.cos, math.sin
        for (i, kind, _, _), d, b, pv in zip(objects, measured_d, measured_b, sighted_pv):
            count[i] += 1
            x, y, theta = est[i]
            heading = theta + b
            gx, gy = _cell(cos(heading) * d + x, size, top_x), _cell(sin(heading) * d + y, size, top_y)
            robot = kind == SEEN_ROBOT
            cell = (NO_CELL, NO_CELL) if robot else (gx, gy)
            table[i, count[i]] = (float(robot), gx, gy, pv * certainty[i], d, b, *cell)  # the class: TARGET 0, ROBOT 1
            any_target = any_target or not robot
    return Sightings(table, count, any_target)
