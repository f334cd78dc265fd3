"""Robot sensors: proximity ring, light sensor, field-of-view camera.

All sensors read a :class:`~teamgym.sim.robot.DiffDriveRobot` in a pymunk space and
return numpy arrays or small records; noise comes from a caller-supplied
``np.random.Generator`` so that seeded runs repeat exactly.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pymunk

from teamgym.sim.categories import OPAQUE, Category
from teamgym.sim.chipmunk import RayCaster
from teamgym.sim.entity import Entity
from teamgym.sim.robot import DiffDriveRobot

#: Directions of the Khepera's eight infrared sensors relative to the heading (radians,
#: counter-clockwise), numbered as in paper 004, Fig. 3: 0 left, 1–4 front, 5 right,
#: 6–7 back. The angles are those of the Khepera I body (±90°, ±45°, ±10°, ±170°).
KHEPERA_RING = np.deg2rad([90.0, 45.0, 10.0, -10.0, -45.0, -90.0, -170.0, 170.0])


class ProximityRing:
    """Ray-cast distance sensors around the robot's rim.

    A reading is the distance (m) from the robot's surface along the ray to the first solid
    object, or ``max_range`` when nothing is within range. Before casting, one bounding-box
    query checks whether anything at all lies within range; if not, the eight casts are
    skipped (they dominate the cost of a simulation step).
    """

    def __init__(self, angles: Iterable[float] = KHEPERA_RING, max_range: float = 0.1, noise_std: float = 0.0) -> None:
        self.angles = np.asarray(list(angles), dtype=float)
        if self.angles.ndim != 1 or len(self.angles) == 0:
            raise ValueError(f"ProximityRing needs at least one ray angle, got {angles!r}")
        if not max_range > 0:
            raise ValueError(f"ProximityRing.max_range must be > 0, got {max_range!r}")
        if not noise_std >= 0:
            raise ValueError(f"ProximityRing.noise_std must be >= 0, got {noise_std!r}")
        self.max_range = float(max_range)
        self.noise_std = float(noise_std)
        self._cos = np.cos(self.angles).tolist()
        self._sin = np.sin(self.angles).tolist()
        self._caster = RayCaster()

    @property
    def n_rays(self) -> int:
        return len(self.angles)

    def read(
        self,
        robot: DiffDriveRobot,
        space: pymunk.Space,
        rng: np.random.Generator | None = None,
        out: np.ndarray | None = None,
        pose: tuple[float, float, float] | None = None,
    ) -> np.ndarray:
        """Distances for every ray into ``out`` (allocated if not given).

        ``pose`` may give the robot's ``(x, y, θ)`` when the caller has it already.
        """
        if out is None:
            out = np.empty(self.n_rays, dtype=np.float32)
        out.fill(self.max_range)
        x, y, theta = pose if pose is not None else (*robot.body.position, robot.body.angle)
        r = robot.spec.radius
        query_filter = robot.sensor_filter
        caster = self._caster
        if caster.anything_within(space, (x, y), r + self.max_range, query_filter):
            c, s = math.cos(theta), math.sin(theta)
            span = self.max_range
            cast = caster.cast
            for i, (ca, sa) in enumerate(zip(self._cos, self._sin)):
                dx, dy = c * ca - s * sa, s * ca + c * sa
                start = (x + r * dx, y + r * dy)
                alpha = cast(space, start, (start[0] + span * dx, start[1] + span * dy), query_filter)
                if alpha is not None:
                    out[i] = alpha * span
        if self.noise_std > 0 and rng is not None:
            out += rng.normal(0.0, self.noise_std, size=self.n_rays)
            np.clip(out, 0.0, self.max_range, out=out)
        return out


class LightSensor:
    """Ambient-light intensity per sensor direction towards a point lamp.

    Reading ``i`` is ``I₀ · max(0, cos(φ − α_i)) / max(d, d_min)²`` where ``φ`` is the lamp's
    bearing, ``α_i`` the sensor direction and ``d`` the distance, or 0 when an opaque object
    blocks the line of sight. Boxes are clear plastic (paper 004) and do not block light.
    ``blockers`` is the category mask of what casts shadows (default :data:`OPAQUE`; 0 for a
    lamp that every robot sees from anywhere, as in paper 004, section 2.1).
    """

    def __init__(
        self,
        lamp: tuple[float, float],
        intensity: float = 1.0,
        angles: Iterable[float] = KHEPERA_RING,
        min_distance: float = 0.05,
        noise_std: float = 0.0,
        blockers: int = OPAQUE,
    ) -> None:
        self.lamp = (float(lamp[0]), float(lamp[1]))
        self.intensity = float(intensity)
        self.angles = np.asarray(list(angles), dtype=float)
        self.min_distance = float(min_distance)
        self.noise_std = float(noise_std)
        self.blockers = int(blockers)

    def read(
        self,
        robot: DiffDriveRobot,
        space: pymunk.Space,
        rng: np.random.Generator | None = None,
        out: np.ndarray | None = None,
        pose: tuple[float, float, float] | None = None,
    ) -> np.ndarray:
        """Intensities into ``out``; ``pose`` may give the robot's ``(x, y, θ)`` if already read."""
        if out is None:
            out = np.empty(len(self.angles), dtype=np.float32)
        x, y, theta = pose if pose is not None else robot.pose
        lx, ly = self.lamp
        d = math.hypot(lx - x, ly - y)
        blocked = False
        if self.blockers and d > 1e-9:
            query_filter = pymunk.ShapeFilter(group=robot.group, mask=self.blockers)
            blocked = space.segment_query_first((x, y), self.lamp, 0.0, query_filter) is not None
        if blocked:
            out.fill(0.0)
        else:
            bearing = math.atan2(ly - y, lx - x) - theta
            gain = self.intensity / max(d, self.min_distance) ** 2
            np.maximum(np.cos(bearing - self.angles) * gain, 0.0, out=out, casting="unsafe")
        if self.noise_std > 0 and rng is not None:
            out += rng.normal(0.0, self.noise_std, size=len(out))
            np.maximum(out, 0.0, out=out)
        return out


@dataclass(frozen=True)
class Sighting:
    """An object seen by a camera: its name, kind and position relative to the robot.

    ``distance`` (m) and ``bearing`` (rad, CCW from the heading) are measured to the
    object's centre; ``x`` and ``y`` are the same in the robot's frame (x forward).
    """

    name: str
    kind: Category
    distance: float
    bearing: float

    @property
    def x(self) -> float:
        return self.distance * math.cos(self.bearing)

    @property
    def y(self) -> float:
        return self.distance * math.sin(self.bearing)


class Camera:
    """A limited-range field-of-view camera that reports the class and position of objects.

    An object is seen when its centre is within ``max_range`` and within ``fov / 2`` of the
    heading and, with ``occlusion``, no other opaque solid lies between.
    """

    def __init__(
        self,
        fov: float = math.radians(60.0),
        max_range: float = 0.5,
        kinds: Iterable[Category] = (Category.ROBOT, Category.BOX, Category.TARGET, Category.OBSTACLE),
        occlusion: bool = True,
    ) -> None:
        if not 0 < fov <= 2 * math.pi:
            raise ValueError(f"Camera.fov must be in (0, 2π], got {fov!r}")
        if not max_range > 0:
            raise ValueError(f"Camera.max_range must be > 0, got {max_range!r}")
        self.fov = float(fov)
        self.max_range = float(max_range)
        self.kinds = frozenset(kinds)
        self.occlusion = occlusion

    def read(self, robot: DiffDriveRobot, entities: Iterable[Entity], space: pymunk.Space) -> list[Sighting]:
        x, y, theta = robot.pose
        seen = []
        query_filter = pymunk.ShapeFilter(group=robot.group, mask=OPAQUE)
        for entity in entities:
            if entity is robot or entity.kind not in self.kinds:
                continue
            ex, ey = entity.position
            d = math.hypot(ex - x, ey - y)
            if d > self.max_range:
                continue
            bearing = float(np.pi - np.mod(np.pi - (math.atan2(ey - y, ex - x) - theta), 2 * np.pi))
            if abs(bearing) > self.fov / 2:
                continue
            if self.occlusion and d > 1e-9:
                hit = space.segment_query_first((x, y), (ex, ey), 0.0, query_filter)
                if hit is not None and getattr(hit.shape, "entity", None) is not entity:
                    continue
            seen.append(Sighting(entity.name, entity.kind, d, bearing))
        return seen
