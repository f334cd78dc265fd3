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
from typing import NamedTuple

import numpy as np

from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.perception import ROBOT, SENDER, TARGET, Odometry, VisionModel, in_view, occluded

assert (TARGET, ROBOT) == (0, 1)  # a detection's class is written as "is a robot"

__all__ = ["NO_CELL", "Cameras", "Sightings", "View", "cells_of", "landmark_fixes", "measure_all", "perceive", "relocalise"]

#: Cell coordinate of the rows of :attr:`Sightings.table` that are not target detections (far from every cell).
NO_CELL = 1.0e6
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
        """Robot i's packet payload: its own tuple and its detections, flat float32 (a new array)."""
        return self.table[i, : 1 + self.count[i], TUPLE].reshape(-1)


class View(NamedTuple):
    """Every robot's true geometry to the points ``[targets, robots, landmarks]`` (:func:`in_view`)."""

    rel: np.ndarray  #: (n, P, 2) offsets (m)
    distance: np.ndarray  #: (n, P) m
    bearing: np.ndarray  #: (n, P) rad, in [−π, π)
    in_sector: np.ndarray  #: (n, P) bool: within the camera's range and opening


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
        n_targets = len(view.distance[0]) - self.n - len(self.landmarks)
        columns, not_self, counted = self._masks_for(tuple(live.tolist()), n_targets)
        rel, distance, bearing, seen = view
        if len(live) < n_targets:
            rel, distance, bearing, seen = rel[:, columns], distance[:, columns], bearing[:, columns], seen[:, columns]
        seen = seen & not_self
        t = len(live)
        # A teammate hides a point only if it is nearer than the camera's range (the point lies within it and
        # the teammate within a radius of the sight line): skipped when every teammate is farther.
        if (
            self.n > 1
            and np.count_nonzero(seen)
            and np.count_nonzero(distance[:, t : t + self.n] + self._self_gap < self.clear_distance)
        ):
            seen &= ~occluded(pose, rel, distance, pose[:, :2], self.radius, counted)
        return seen, distance, bearing

    def blank(self, n_slots: int) -> np.ndarray:
        """An empty :attr:`Sightings.table` (a new array): zeros, :data:`NO_CELL` in the target-cell columns."""
        if self._blank is None or self._blank.shape[1] != 1 + n_slots:
            self._blank = np.zeros((self.n, 1 + n_slots, 8), dtype=np.float32)
            self._blank[:, :, TARGET_CELL] = NO_CELL
        return self._blank.copy()


def landmark_fixes(
    certainty: np.ndarray, seen: np.ndarray, distance: np.ndarray, bearing: np.ndarray, pv: np.ndarray, live: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The ``live`` robots whose nearest landmark in view (sightings (n, L) with their Pv) re-localises them (Pv ≥ Pl).

    Returns their rows (in index order) and that landmark's true distance, bearing and Pv, or None.
    """
    candidates = np.logical_or.reduce(seen, axis=1)
    candidates &= live
    if not np.count_nonzero(candidates):
        return None
    robots = np.arange(len(seen))
    nearest = np.argmin(np.where(seen, distance, np.inf), axis=1)
    sighted = pv[robots, nearest]
    candidates &= sighted >= certainty
    count = np.count_nonzero(candidates)
    if not count:
        return None
    if count < len(robots):
        robots = np.flatnonzero(candidates)
        nearest, sighted = nearest[robots], sighted[robots]
    return robots, distance[robots, nearest], bearing[robots, nearest], sighted


def relocalise(
    odometry: Odometry, pose: np.ndarray, fixes: tuple[np.ndarray, ...], measured_d: np.ndarray, measured_b: np.ndarray
) -> None:
    """Re-localise the robots of :func:`landmark_fixes` from their landmark's measured distance and bearing."""
    rows, d, b, pv = fixes
    # The pose implied by the measured landmark differs from the truth by the measurement error.
    errors = np.empty((len(rows), 3))
    for k, (i, true_d, true_b, m_d, m_b) in enumerate(
        zip(rows.tolist(), d.tolist(), b.tolist(), measured_d.tolist(), measured_b.tolist())
    ):
        theta = float(pose[i, 2])
        ray, measured_ray = theta + true_b, theta + m_b
        errors[k] = (
            true_d * math.cos(ray) - m_d * math.cos(measured_ray),
            true_d * math.sin(ray) - m_d * math.sin(measured_ray),
            true_b - m_b,
        )
    odometry.relocalise_rows(rows, pose[rows], pv, errors)


def measure_all(
    vision: VisionModel, sightings: tuple[np.ndarray, ...], fixes: tuple[np.ndarray, ...] | None, rng: np.random.Generator
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Measured (distance, bearing) of the object sightings (true distance, bearing, Pv) and of the landmark fixes.

    One draw serves both, in the order of the paper's model run robot by robot: the distance
    errors of every object sighting, then their bearing errors, then each re-localising
    robot's distance and bearing error.
    """
    d, b, pv = sightings
    m = len(d)
    r = 0 if fixes is None else len(fixes[0])
    if vision.noise == 0.0 or not m + r:
        return (d, b), ((fixes[1], fixes[2]) if r else (d[:0], b[:0]))
    noise = rng.standard_normal(2 * (m + r))
    if r:
        d, b, pv = np.concatenate([d, fixes[1]]), np.concatenate([b, fixes[2]]), np.concatenate([pv, fixes[3]])
        distance_noise = np.concatenate([noise[:m], noise[2 * m :: 2]])
        bearing_noise = np.concatenate([noise[m : 2 * m], noise[2 * m + 1 :: 2]])
    else:
        distance_noise, bearing_noise = noise[:m], noise[m:]
    measured_d, measured_b = vision.measure_with(d, b, pv, distance_noise, bearing_noise)
    return (measured_d[:m], measured_b[:m]), (measured_d[m:], measured_b[m:])


def perceive(
    cameras: Cameras,
    grid: GridSpec,
    vision: VisionModel,
    odometry: Odometry,
    pose: np.ndarray,
    view: View,
    live_targets: np.ndarray,
    live: np.ndarray,
    n_slots: int,
    rng: np.random.Generator,
) -> Sightings:
    """One sensing phase: the sightings of every robot (see the module docstring).

    ``view``: :meth:`Cameras.view` at ``pose``; ``live_targets``: indices of the live targets;
    ``live`` (n,) bool: robots in the episode (only they re-localise). Random draws, in order:
    the measurement errors of every target and teammate sighting (row-major: per robot,
    targets before robots), then the re-localisations' (:func:`measure_all`). A tuple's
    position and Pc use the odometry after the re-localisation.
    """
    n, t = len(pose), len(live_targets)
    seen, distance, bearing = cameras.seen(pose, view, live_targets)
    pv = vision.pv(distance, bearing)
    objects = seen[:, : t + n]
    rows, cols = np.nonzero(objects)  # row-major: per robot, targets before robots
    sighted = distance[:, : t + n][objects], bearing[:, : t + n][objects], pv[:, : t + n][objects]
    landmarks = slice(t + n, None)
    fixes = landmark_fixes(
        odometry.certainty, seen[:, landmarks], distance[:, landmarks], bearing[:, landmarks], pv[:, landmarks], live
    )
    (measured_d, measured_b), fixed = measure_all(vision, sighted, fixes, rng)
    if fixes is not None:
        relocalise(odometry, pose, fixes, *fixed)
    pv_seen = sighted[2]
    est, certainty = odometry.estimate, odometry.certainty
    table = cameras.blank(n_slots)
    own = table[:, 0]
    own[:, 0] = SENDER
    own[:, 1:3] = cells_of(grid, est[:, :2])
    own[:, 3] = certainty
    count = np.bincount(rows, minlength=n)
    any_target = False
    if len(rows):
        values = np.empty((len(rows), 8))
        seer = est[rows]
        heading = seer[:, 2] + measured_b
        position = values[:, 1:3]
        np.cos(heading, out=values[:, 1])
        np.sin(heading, out=values[:, 2])
        position *= measured_d[:, None]
        position += seer[:, :2]
        position[:] = cells_of(grid, position)
        robot = cols >= t
        values[:, 0] = robot  # the class: TARGET 0, ROBOT 1
        np.multiply(pv_seen, certainty[rows], out=values[:, 3])
        values[:, 4] = measured_d
        values[:, 5] = measured_b
        values[:, 6:8] = position
        values[robot, 6:8] = NO_CELL
        table[rows, 1 + np.arange(len(rows)) - np.searchsorted(rows, rows)] = values
        any_target = len(rows) > np.count_nonzero(robot)
    return Sightings(table, count, any_target)
