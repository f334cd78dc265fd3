"""The sensing phase of ``Foraging-v0`` over all robots at once: cameras, re-localisation, perception tuples.

:class:`Cameras` looks with every robot's camera at the live targets, the teammates and the
landmarks in one pass (the geometry of :func:`~teamgym.envs.foraging.perception.visibility`,
with its occlusion masks built once per number of live targets). :func:`perceive` runs the
phase: sightings, their measurement errors, re-localisation at landmarks (:func:`relocalise`)
and the perception tuples of section 2.1 (eq. 1), as the packets every robot broadcasts: one
``(n, 1 + D, 4)`` float32 array whose row 0 is the sender's own tuple.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from teamgym.envs.foraging.grid import GridSpec
from teamgym.envs.foraging.perception import ROBOT, SENDER, TARGET, Odometry, VisionModel, in_view, occluded

__all__ = ["Cameras", "Sightings", "perceive", "relocalise"]

#: Cell coordinate of a padding row in :attr:`Sightings.target_cells` (never within a cell of a go-to cell).
NO_CELL = 1 << 20


class Sightings(NamedTuple):
    """What the robots perceive in one sensing phase (rows: robots in ``possible_agents`` order)."""

    packets: np.ndarray  #: (n, 1 + D, 4) float32: the own tuple ``(SENDER, gx, gy, Pl)``, then the detections
    polar: np.ndarray  #: (n, D, 2) float32: measured distance and bearing of each detection, 0 for padding
    count: np.ndarray  #: (n,) int: detections per robot
    target_cells: np.ndarray  #: (n, D, 2) int: cells of the target detections, :data:`NO_CELL` elsewhere

    @property
    def detections(self) -> np.ndarray:
        """(n, D, 4) float32: the tuples ``(class, gx, gy, Pc)``, targets first, zero padding."""
        return self.packets[:, 1:]


class Cameras:
    """Every robot's forward camera: which targets, teammates and landmarks it sees (see the module docstring)."""

    def __init__(self, n_robots: int, landmarks: np.ndarray, camera_range: float, camera_fov: float, robot_radius: float):
        self.n = int(n_robots)
        self.landmarks = np.asarray(landmarks, dtype=float).reshape(-1, 2)
        self.camera_range, self.camera_fov, self.radius = float(camera_range), float(camera_fov), float(robot_radius)
        self._masks: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def _masks_for(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """For ``t`` live targets: (n, P) points a robot may see (not itself) and (n, P, n) occluders that count."""
        if t not in self._masks:
            n = self.n
            points = t + n + len(self.landmarks)
            not_self = np.ones((n, points), dtype=bool)
            not_self[np.arange(n), t + np.arange(n)] = False
            counted = np.ones((n, points, n), dtype=bool)
            counted[np.arange(n), :, np.arange(n)] = False  # a robot does not hide its own view
            counted[:, t + np.arange(n), np.arange(n)] = False  # nor a teammate itself
            self._masks[t] = (not_self, counted)
        return self._masks[t]

    def look(self, pose: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Seen (n, P) bool, true distances and bearings (n, P) of the points ``[targets, robots, landmarks]``.

        ``pose`` (n, 3): the robots' true poses; ``targets`` (t, 2): the live targets.
        """
        not_self, counted = self._masks_for(len(targets))
        points = np.concatenate([targets, pose[:, :2], self.landmarks])
        rel, distance, bearing, seen = in_view(pose, points, self.camera_range, self.camera_fov)
        seen &= not_self
        if self.n > 1 and seen.any():
            seen &= ~occluded(pose, rel, distance, pose[:, :2], self.radius, counted)
        return seen, distance, bearing


def relocalise(
    odometry: Odometry,
    vision: VisionModel,
    pose: np.ndarray,
    seen: np.ndarray,
    distance: np.ndarray,
    bearing: np.ndarray,
    live: np.ndarray,
    rng: np.random.Generator,
) -> None:
    """Landmark sightings (n, L): the nearest landmark in view re-localises a ``live`` robot when its Pv ≥ Pl.

    The robots go in index order, each drawing its sighting's measurement error in turn, so
    the random stream is that of one robot at a time.
    """
    candidates = np.flatnonzero(seen.any(axis=1) & live)
    if not len(candidates):
        return
    nearest = np.argmin(np.where(seen[candidates], distance[candidates], np.inf), axis=1)
    d, b = distance[candidates, nearest], bearing[candidates, nearest]
    pv = vision.pv(d, b)
    keep = pv >= odometry.certainty[candidates]
    if not keep.any():
        return
    rows, d, b, pv = candidates[keep], d[keep], b[keep], pv[keep]
    if vision.noise == 0.0:
        d_m, b_m = d, b
    else:  # one robot's (distance, bearing) errors after the other's
        noise = rng.standard_normal(2 * len(rows)).reshape(len(rows), 2)
        d_m, b_m = vision.measure_with(d, b, pv, noise[:, 0], noise[:, 1])
    # The pose implied by the measured landmark differs from the truth by the measurement error.
    errors = np.empty((len(rows), 3))
    for k, (i, true_d, true_b, m_d, m_b) in enumerate(zip(rows.tolist(), d.tolist(), b.tolist(), d_m.tolist(), b_m.tolist())):
        theta = float(pose[i, 2])
        ray, measured_ray = theta + true_b, theta + m_b
        errors[k] = (
            true_d * math.cos(ray) - m_d * math.cos(measured_ray),
            true_d * math.sin(ray) - m_d * math.sin(measured_ray),
            true_b - m_b,
        )
    odometry.relocalise_rows(rows, pose[rows], pv, errors)


def perceive(
    cameras: Cameras,
    grid: GridSpec,
    vision: VisionModel,
    odometry: Odometry,
    pose: np.ndarray,
    targets: np.ndarray,
    live: np.ndarray,
    n_slots: int,
    rng: np.random.Generator,
) -> tuple[Sightings, bool]:
    """One sensing phase: the sightings of every robot and whether any robot saw a target.

    ``targets`` (t, 2): the live targets; ``live`` (n,) bool: robots in the episode (only they
    re-localise). Random draws, in order: the measurement errors of every target and teammate
    sighting (row-major: per robot, targets before robots), then the re-localisations. A
    tuple's position and Pc use the odometry after the re-localisation.
    """
    n, t = len(pose), len(targets)
    seen, distance, bearing = cameras.look(pose, targets)
    objects = seen[:, : t + n]
    rows, cols = np.nonzero(objects)  # row-major: per robot, targets before robots
    d_true, b_true = distance[:, : t + n][objects], bearing[:, : t + n][objects]
    pv = vision.pv(d_true, b_true)
    measured_d, measured_b = vision.measure(d_true, b_true, pv, rng) if len(rows) else (d_true, b_true)
    relocalise(odometry, vision, pose, seen[:, t + n :], distance[:, t + n :], bearing[:, t + n :], live, rng)
    est, certainty = odometry.estimate, odometry.certainty
    packets = np.zeros((n, 1 + n_slots, 4), dtype=np.float32)
    packets[:, 0, 0] = SENDER
    packets[:, 0, 1:3] = grid.cell_of(est[:, :2])
    packets[:, 0, 3] = certainty
    polar = np.zeros((n, n_slots, 2), dtype=np.float32)
    target_cells = np.full((n, n_slots, 2), NO_CELL, dtype=np.int64)
    count = np.bincount(rows, minlength=n)
    if len(rows):
        slots = np.arange(len(rows)) - np.searchsorted(rows, rows)
        heading = est[rows, 2] + measured_b
        offset = np.empty((len(rows), 2))
        np.cos(heading, out=offset[:, 0])
        np.sin(heading, out=offset[:, 1])
        offset *= measured_d[:, None]
        cells = grid.cell_of(est[rows, :2] + offset)
        is_target = cols < t
        tuples = packets[rows, 1 + slots]
        tuples[:, 0] = np.where(is_target, TARGET, ROBOT)
        tuples[:, 1:3] = cells
        tuples[:, 3] = pv * certainty[rows]
        packets[rows, 1 + slots] = tuples
        polar[rows, slots, 0] = measured_d
        polar[rows, slots, 1] = measured_b
        target_cells[rows[is_target], slots[is_target]] = cells[is_target]
    return Sightings(packets, polar, count, target_cells), bool(seen[:, :t].any())
