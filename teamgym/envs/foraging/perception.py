"""Perception of paper 002: a forward camera with occlusion, the vision look-up table (Pv),
odometry with rotational error and its certainty (Pl, eq. 2), and perception tuples (eq. 1).

**Tuples** (section 2.1): every object a robot sees becomes ``(class, gx, gy, Pc)``: class
:data:`TARGET` or :data:`ROBOT` (:data:`SENDER` marks a transmitting robot's own location in
a packet, with Pc = its Pl), the grid cell of the object's estimated global position and the
confidence Pc = Pv · Pl (eq. 1).

**Vision (Pv)**: the paper fills a look-up table from experiments that relates the distance
and bearing of an object to the measurement error. Ours, :data:`PV_TABLE`, gives Pv per
distance bin (a quarter of the camera range each) and |bearing| bin (a third of the half
opening each); the measurement errors follow from it: σ_d = ``vision_noise`` · 0.3 m · (1 − Pv)
and σ_b = ``vision_noise`` · 0.2 rad · (1 − Pv), so a near, centred object (Pv 0.95) is
measured to 1.5 cm and 0.01 rad, a far one at the edge of view (Pv 0.5) to 15 cm and 0.1 rad.

**Localisation (Pl, eq. 2, lost in the text)**: reconstructed from the sentences around it:
"d and θ are the traversing and rotational components of incremental navigation steps; Pe
is the rotational certainty from the robot's characteristic model; the traversing part is
not accounted for; Pl decreases as the robot travels and is reset to the Pv of a landmark
sighting". We read it as a certainty that shrinks geometrically with the rotation::

    Pl_k = Pl_{k-1} · Pe^{|Δθ_k|}        (Δθ_k: rotation in control step k, rad)

(the traversing term d is dropped as the text says). The true odometry error grows the same
way: the heading estimate gains N(0, (σ_r |Δθ|)²) per step and the position estimate
integrates the true displacement along the estimated heading, with N(0, (σ_t d)²) on its
length. A landmark in view whose Pv is at least the current Pl re-localises the robot: the
estimate is set to the truth plus that sighting's measurement error and Pl = Pv.

**Occlusion**: the field is a convex walled rectangle, so walls hide nothing inside it;
robots (discs) hide what lies behind them. Targets are points and hide nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from teamgym.envs.foraging.grid import GridSpec

__all__ = [
    "PACKET_KIND",
    "PV_TABLE",
    "ROBOT",
    "SENDER",
    "TARGET",
    "Odometry",
    "VisionModel",
    "landmark_positions",
    "packet_bytes",
    "in_view",
    "occluded",
    "visibility",
]

#: Channel message kind of the perception packets.
PACKET_KIND = "perception"
#: Tuple classes (the first element of a perception tuple).
TARGET, ROBOT, SENDER = 0, 1, 2

#: Pv by distance bin (rows: [0, ¼), [¼, ½), [½, ¾), [¾, 1] of the camera range) and |bearing|
#: bin (columns: [0, ⅓), [⅓, ⅔), [⅔, 1] of half the opening).
PV_TABLE = np.array(
    [
        [0.95, 0.92, 0.88],
        [0.90, 0.86, 0.80],
        [0.80, 0.75, 0.68],
        [0.65, 0.60, 0.50],
    ]
)
_PV_ROWS = PV_TABLE.tolist()
#: Measurement errors per unit of (1 − Pv) at ``vision_noise`` = 1: metres and radians.
DISTANCE_ERROR, BEARING_ERROR = 0.3, 0.2
#: How far beyond ``camera_range`` a measured distance can read (m): the camera saturates there.
MEASURED_RANGE_MARGIN = 1.0


def packet_bytes(n_tuples: int, grid: GridSpec) -> int:
    """Bytes of a perception packet (section 4.3): the sender's tuple plus ``n_tuples`` objects.

    Three object lists (sender, robots, targets) with a one-byte header each; a tuple is its
    cell (one byte on the paper's 180-cell grid, :attr:`GridSpec.location_bytes`) plus one
    byte of confidence. Two robots seeing three targets and each other: 3 + 5·2 = 13 bytes,
    the paper's "around 12 bytes".
    """
    return 3 + (1 + int(n_tuples)) * (grid.location_bytes + 1)


def landmark_positions(width: float, height: float, spacing: float) -> np.ndarray:
    """Landmarks along the walls: the corners and points about ``spacing`` m apart between them."""
    points = []
    corners = [(0.0, 0.0), (width, 0.0), (width, height), (0.0, height)]
    for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1]):
        n = max(1, round(math.hypot(x1 - x0, y1 - y0) / spacing))
        for k in range(n):
            t = k / n
            points.append((x0 + t * (x1 - x0), y0 + t * (y1 - y0)))
    return np.array(points)


def visibility(
    poses: np.ndarray,
    points: np.ndarray,
    camera_range: float,
    camera_fov: float,
    occluders: np.ndarray,
    occluder_radius: float,
    skip: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which ``points`` (m, 2) each camera of ``poses`` (n, 3) sees, and their true distances and bearings.

    A point is seen if it lies within ``camera_range`` and half of ``camera_fov`` of the heading
    and no occluder disc (centres ``occluders`` (k, 2), radius ``occluder_radius``) other than
    the viewer crosses the line of sight before the point. ``skip[i, j]`` = occluder index to
    ignore for viewer i and point j (the point's own robot), −1 for none. Returns bool (n, m),
    distances (n, m), bearings (n, m).
    """
    rel, distance, bearing, seen = in_view(poses, points, camera_range, camera_fov)
    n, m, k = len(poses), len(points), len(occluders)
    if not seen.any() or k < 2:
        return seen, distance, bearing
    counted = np.ones((n, m, k), dtype=bool)
    if k == n:  # occluders are the viewers themselves: a robot does not hide its own view
        counted[np.arange(n), :, np.arange(n)] = False
    if skip is not None:
        rows, cols = np.nonzero(skip >= 0)
        counted[rows, cols, skip[rows, cols]] = False
    return seen & ~occluded(poses, rel, distance, occluders, occluder_radius, counted), distance, bearing


def in_view(
    poses: np.ndarray, points: np.ndarray, camera_range: float, camera_fov: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Offsets (n, m, 2) of ``points`` from every camera, their distances and bearings (n, m), and whether
    they lie in the camera's sector (n, m) bool, occlusion aside (see :func:`visibility`)."""
    rel = points[None, :, :] - poses[:, None, :2]
    distance = np.hypot(rel[..., 0], rel[..., 1])
    bearing = np.arctan2(rel[..., 1], rel[..., 0])
    bearing -= poses[:, None, 2]
    bearing += math.pi
    bearing %= 2 * math.pi
    bearing -= math.pi
    seen = distance <= camera_range
    seen &= np.abs(bearing) <= 0.5 * camera_fov
    return rel, distance, bearing, seen


def occluded(
    poses: np.ndarray, rel: np.ndarray, distance: np.ndarray, occluders: np.ndarray, radius: float, counted: np.ndarray
) -> np.ndarray:
    """Whether a disc of ``occluders`` (k, 2) whose ``counted[i, j, k]`` is set hides point j from camera i (n, m) bool.

    ``rel`` and ``distance``: the points' offsets and distances from :func:`in_view`. Occluder k
    blocks the sight line i → j if its centre projects onto the line between the camera and
    ``radius`` short of the point and lies less than ``radius`` from it.
    """
    ox = occluders[None, :, 0] - poses[:, 0, None]  # (n, k)
    oy = occluders[None, :, 1] - poses[:, 1, None]
    safe = np.maximum(distance, 1e-12)
    ux, uy = rel[..., 0] / safe, rel[..., 1] / safe  # (n, m)
    along = ux[:, :, None] * ox[:, None, :] + uy[:, :, None] * oy[:, None, :]
    across2 = (ox * ox + oy * oy)[:, None, :] - along**2
    blocks = (along > 0) & (along < distance[..., None] - radius) & (across2 < radius**2)
    blocks &= counted
    return blocks.any(axis=-1)


@dataclass(frozen=True)
class VisionModel:
    """Pv by distance and bearing (:data:`PV_TABLE`) and the measurement errors it implies."""

    camera_range: float
    camera_fov: float
    noise: float = 1.0

    def pv(self, distance: np.ndarray, bearing: np.ndarray) -> np.ndarray:
        """Pv of objects at ``distance`` (m) and ``bearing`` (rad) from the camera."""
        rows = np.minimum((np.asarray(distance) / self.camera_range * 4).astype(np.int64), 3)
        cols = np.minimum((np.abs(bearing) / (0.5 * self.camera_fov) * 3).astype(np.int64), 2)
        return PV_TABLE[rows, cols]

    def pv_of(self, distance: float, bearing: float) -> float:
        """:meth:`pv` of one object (the same float operations)."""
        row = min(int(distance / self.camera_range * 4), 3)
        col = min(int(abs(bearing) / (0.5 * self.camera_fov) * 3), 2)
        return _PV_ROWS[row][col]

    @property
    def max_distance(self) -> float:
        """The largest measured distance (m): ``camera_range + MEASURED_RANGE_MARGIN``."""
        return self.camera_range + MEASURED_RANGE_MARGIN

    def measure(
        self, distance: np.ndarray, bearing: np.ndarray, pv: np.ndarray, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """Measured ``(distance, bearing)`` with errors N(0, σ_d²), N(0, σ_b²) set by ``pv``.

        A measured distance lies in ``[0, max_distance]`` (the camera saturates) and a bearing
        in ``[-π, π]`` (one that the error takes beyond is wrapped).
        """
        if self.noise == 0.0:
            return np.asarray(distance, dtype=float), np.asarray(bearing, dtype=float)
        noise = rng.standard_normal((2, *np.shape(distance)))
        return self.measure_with(distance, bearing, pv, noise[0], noise[1])

    def measure_one(
        self, distance: float, bearing: float, pv: float, distance_noise: float, bearing_noise: float
    ) -> tuple[float, float]:
        """:meth:`measure_with` of one object (``noise`` > 0; the same float operations)."""
        spread = self.noise * (1.0 - pv)
        measured = min(max(0.0, distance + DISTANCE_ERROR * spread * distance_noise), self.max_distance)
        turned = bearing + BEARING_ERROR * spread * bearing_noise
        if abs(turned) > math.pi:
            turned = (turned + math.pi) % (2 * math.pi) - math.pi
        return measured, turned

    def measure_with(
        self, distance: np.ndarray, bearing: np.ndarray, pv: np.ndarray, distance_noise: np.ndarray, bearing_noise: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`measure` with its standard normal draws given (``noise`` > 0)."""
        spread = self.noise * (1.0 - pv)
        measured = np.minimum(np.maximum(0.0, distance + DISTANCE_ERROR * spread * distance_noise), self.max_distance)
        turned = bearing + BEARING_ERROR * spread * bearing_noise
        beyond = np.abs(turned) > math.pi
        if np.count_nonzero(beyond):
            turned = np.where(beyond, (turned + math.pi) % (2 * math.pi) - math.pi, turned)
        return measured, turned


class Odometry:
    """Every robot's pose estimate and localisation certainty Pl (eq. 2, see the module docstring)."""

    def __init__(self, true_poses: np.ndarray, rotational_certainty: float, rotation_noise: float, distance_noise: float):
        self.estimate = np.array(true_poses, dtype=float)
        self.certainty = np.ones(len(true_poses))
        self.pe = rotational_certainty
        self.rotation_noise = rotation_noise
        self.distance_noise = distance_noise

    def advance(
        self,
        before: np.ndarray,
        after: np.ndarray,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """Integrate one control step of the motion ``before`` → ``after`` (rows x, y, θ); returns the displacements (n, 2).

        :meth:`advance_rows` on arrays.
        """
        return np.array(self.advance_rows(before.tolist(), after.tolist(), rng), dtype=float).reshape(len(before), 2)

    def advance_rows(
        self,
        before: list[list[float]],
        after: list[list[float]],
        rng: np.random.Generator,
    ) -> list[tuple[float, float]]:
        """:meth:`advance` of pose rows as lists; returns the displacements ``(dx, dy)`` per robot.

        Per robot in scalar float arithmetic (the same IEEE operations, in the same order, as the
        array form; ``math.cos``/``math.sin`` and ``**`` are libm's, as numpy's float64 ones),
        the certainty factor ``Pe^{|Δθ|}`` per robot (eq. 2).
        """
        turn_noise, length_noise = rng.standard_normal((2, len(before))).tolist()
        two_pi, pi, distance_noise, rotation_noise = 2 * math.pi, math.pi, self.distance_noise, self.rotation_noise
        pe, cos, sin = self.pe, math.cos, math.sin
        steps, estimate, certainty = [], [], []
        rows = zip(before, after, self.estimate.tolist(), self.certainty.tolist(), turn_noise, length_noise)
        for (x0, y0, th0), (x1, y1, th1), (ex, ey, eth), pl, turn_noise_i, length_noise_i in rows:
            dx, dy = x1 - x0, y1 - y0
            c, s, ce, se = cos(th0), sin(th0), cos(eth), sin(eth)
            turn = (th1 - th0 + pi) % two_pi - pi
            forward, lateral = dx * c + dy * s, dy * c - dx * s  # the motion in the robot's frame at the start
            scale = distance_noise * length_noise_i * (1.0 if forward != 0.0 or lateral != 0.0 else 0.0) + 1.0
            size = abs(turn)
            heading = (eth + turn + rotation_noise * size * turn_noise_i + pi) % two_pi - pi
            estimate.append((ex + (forward * ce - lateral * se) * scale, ey + (lateral * ce + forward * se) * scale, heading))
            certainty.append(pl * pe**size)
            steps.append((dx, dy))
        self.estimate[:] = estimate
        self.certainty[:] = certainty
        return steps

    def relocalise(self, robot: int, true_pose: np.ndarray, pv: float, error: tuple[float, float, float]) -> None:
        """A landmark sighting: the estimate becomes the truth plus ``error`` (dx, dy, dθ) and Pl = Pv."""
        self.estimate[robot] = true_pose + np.asarray(error)
        self.estimate[robot, 2] = (self.estimate[robot, 2] + math.pi) % (2 * math.pi) - math.pi
        self.certainty[robot] = pv
