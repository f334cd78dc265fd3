"""Robot sensors: proximity ring, light sensor, field-of-view camera, wheel encoders.

Every sensor follows the :class:`Sensor` protocol: ``read_rows`` writes ``width`` values per
robot into a preallocated ``(k, width)`` array, for ``k`` robots at given poses. Noise comes
from a caller-supplied ``np.random.Generator`` and is drawn robot after robot, in the same
order as reading the robots one at a time, so seeded runs repeat exactly.
:class:`SensorSuite` reads several sensors robot by robot into one row per robot.

The older per-robot ``read`` methods remain and share the code of ``read_rows``.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
import pymunk

from teamgym.sim import kernel
from teamgym.sim.categories import OPAQUE, Category
from teamgym.sim.chipmunk import RayCaster
from teamgym.sim.entity import Entity
from teamgym.sim.libm import libm
from teamgym.sim.robot import DiffDriveRobot

if TYPE_CHECKING:
    from teamgym.sim.world import World

Point = tuple[float, float]

#: Directions of the Khepera's eight infrared sensors relative to the heading (radians,
#: counter-clockwise), numbered as in paper 004, Fig. 3: 0 left, 1–4 front, 5 right,
#: 6–7 back. The angles are those of the Khepera I body (±90°, ±45°, ±10°, ±170°).
KHEPERA_RING = np.deg2rad([90.0, 45.0, 10.0, -10.0, -45.0, -90.0, -170.0, 170.0])


@runtime_checkable
class Sensor(Protocol):
    """A sensor that reads ``width`` values per robot."""

    @property
    def width(self) -> int:
        """Values per robot."""
        ...

    def read_rows(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        rng: np.random.Generator | None,
        out: np.ndarray,
    ) -> None:
        """Write the readings of ``robots`` into ``out`` (shape ``(k, width)``), one row per robot.

        ``poses`` holds ``(x, y, θ)`` of each robot in its first three columns (e.g. rows of
        ``world.robot_states``). ``rng`` draws the noise (``None``: no noise).
        """
        ...


def _check_rows(sensor: Sensor, robots: Sequence[DiffDriveRobot], poses: np.ndarray, out: np.ndarray) -> list[list[float]]:
    """The poses as lists ``[x, y, θ]``, after checking the shapes of ``poses`` and ``out``."""
    _check_shapes(sensor, robots, poses, out)
    return poses[:, :3].tolist()


def _check_shapes(sensor: Sensor, robots: Sequence[DiffDriveRobot], poses: np.ndarray, out: np.ndarray) -> None:
    """Raise unless ``poses`` has a row ``(x, y, θ, …)`` and ``out`` a row of the sensor's width per robot."""
    k = len(robots)
    if out.shape != (k, sensor.width):
        raise ValueError(f"{type(sensor).__name__}.read_rows: out must have shape {(k, sensor.width)}, got {out.shape}")
    if poses.ndim != 2 or poses.shape[0] != k or poses.shape[1] < 3:
        raise ValueError(f"{type(sensor).__name__}.read_rows: poses must have shape ({k}, 3), got {poses.shape}")


class NoisyRowSensor:
    """Shared reading logic of the per-robot sensors (proximity ring, light sensor).

    A subclass gives ``width``, :meth:`_read_one` (the noise-free values of one robot) and
    :meth:`_clip` (the valid range after noise). Three kinds of error, each off at 0:

    * ``gain_spread``: every sensor of every robot has its own sensitivity, a gain
      ``exp(N(0, gain_spread²))`` drawn once by :meth:`calibrate` (a robot never calibrated
      has gain 1) — fixed per robot, so averaging readings does not remove it;
    * ``relative_noise``: each reading is multiplied by ``1 + N(0, relative_noise²)``;
    * ``noise_std``: then ``N(0, noise_std²)`` is added (sensor units).

    :meth:`_noise_mask` may exempt readings from the gain and the relative noise (a
    proximity ray that hits nothing). Noise is drawn robot after robot (``(k, 2, width)``
    standard normals when both kinds are on, else one ``(k, width)`` draw), so reading rows
    equals reading the robots one by one.
    """

    width: int
    noise_std: float = 0.0
    relative_noise: float = 0.0
    gain_spread: float = 0.0

    def _read_one(self, robot: DiffDriveRobot, space: pymunk.Space, x: float, y: float, theta: float, out: np.ndarray) -> None:
        raise NotImplementedError

    def _clip(self, out: np.ndarray) -> None:
        raise NotImplementedError

    def _noise_mask(self, out: np.ndarray) -> np.ndarray | None:
        """Readings that the gain and the relative noise apply to (``None``: all)."""
        return None

    def _set_noise(self, noise_std: float, relative_noise: float, gain_spread: float) -> None:
        for key, value in (("noise_std", noise_std), ("relative_noise", relative_noise), ("gain_spread", gain_spread)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{type(self).__name__}.{key} must be a finite number >= 0, got {value!r}")
        self.noise_std = float(noise_std)
        self.relative_noise = float(relative_noise)
        self.gain_spread = float(gain_spread)
        self._gains: dict[str, np.ndarray] = {}

    def calibrate(self, robot: DiffDriveRobot, rng: np.random.Generator) -> None:
        """Draw ``robot``'s sensor gains (``width`` values from ``rng``; nothing is drawn if ``gain_spread`` is 0)."""
        gains = self.draw_gains(rng)
        if gains is not None:
            self._gains[robot.name] = gains

    def draw_gains(self, rng: np.random.Generator) -> np.ndarray | None:
        """One robot's sensor gains ``exp(N(0, gain_spread²))`` (``None``, nothing drawn, if ``gain_spread`` is 0).

        For a caller that keeps the gains itself and passes them to :meth:`read_drawn`.
        """
        if self.gain_spread > 0:
            return np.exp(rng.normal(0.0, self.gain_spread, size=self.width))
        return None

    def gains(self, robot: DiffDriveRobot) -> np.ndarray:
        """``robot``'s sensor gains (ones if it was never calibrated)."""
        return self._gains.get(robot.name, np.ones(self.width)).copy()

    def forget_calibrations(self) -> None:
        """Drop every robot's gains (a new episode's robots are calibrated anew)."""
        self._gains.clear()

    def read(
        self,
        robot: DiffDriveRobot,
        space: pymunk.Space,
        rng: np.random.Generator | None = None,
        out: np.ndarray | None = None,
        pose: tuple[float, float, float] | None = None,
    ) -> np.ndarray:
        """One robot's values into ``out`` (allocated if not given); ``pose`` may give its ``(x, y, θ)``."""
        if out is None:
            out = np.empty(self.width, dtype=np.float32)
        x, y, theta = pose if pose is not None else (*robot.body.position, robot.body.angle)
        self._read_one(robot, space, x, y, theta, out)
        self._add_noise(rng, out[None, :], [robot])
        return out

    def read_rows(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        rng: np.random.Generator | None,
        out: np.ndarray,
        free: Sequence[bool] | None = None,
    ) -> None:
        """Readings of ``robots`` (poses ``(x, y, θ, ...)`` per row) into the rows of ``out``, noise included.

        ``free`` (optional, one flag per robot) marks robots the caller knows have nothing within
        the sensor's reach; their rows read :meth:`_free_reading` without a query (same values).
        """
        self.read_values(world, robots, poses, out, free)
        self._add_noise(rng, out, robots)

    def read_drawn(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        z: np.ndarray | None,
        out: np.ndarray,
        gains: np.ndarray | None = None,
    ) -> None:
        """:meth:`read_rows` with the noise's standard normals given: ``z`` ``(k, noise_size)`` (``None``: no noise).

        ``gains``: the robots' sensor gains ``(k, width)`` when the caller keeps them (``None``:
        those of :meth:`calibrate`).
        """
        self.read_values(world, robots, poses, out, None)
        self.apply_noise(z, out, robots, gains)

    def read_values(
        self, world: World, robots: Sequence[DiffDriveRobot], poses: np.ndarray, out: np.ndarray, free: Sequence[bool] | None
    ) -> None:
        """Noise-free readings (before gains) of ``robots`` into the rows of ``out``."""
        space = world.space
        rows = _check_rows(self, robots, poses, out)
        if free is None:
            for robot, (x, y, theta), row in zip(robots, rows, out):
                self._read_one(robot, space, x, y, theta, row)
        else:
            for robot, (x, y, theta), row, nothing in zip(robots, rows, out, free):
                if nothing:
                    self._free_reading(row)
                else:
                    self._read_one(robot, space, x, y, theta, row)

    def _free_reading(self, out: np.ndarray) -> None:
        """Noise-free reading of a robot with nothing within reach (subclasses that accept ``free`` define it)."""
        raise NotImplementedError(f"{type(self).__name__} does not take free rows")

    @property
    def noiseless(self) -> bool:
        """Whether readings carry no noise and no gains (then they draw nothing from the random stream)."""
        return self.noise_std == 0 and self.relative_noise == 0 and not self._gains

    @property
    def noise_size(self) -> int:
        """Standard normals drawn per robot: ``width`` per kind of noise that is on (relative, additive)."""
        return self.width * ((self.relative_noise > 0) + (self.noise_std > 0))

    def _add_noise(self, rng: np.random.Generator | None, out: np.ndarray, robots: Sequence[DiffDriveRobot]) -> None:
        """Gains, relative and additive noise on the rows ``out`` of ``robots`` (see the class docstring)."""
        size = self.noise_size if rng is not None else 0
        self.apply_noise(rng.standard_normal((len(out), size)) if size else None, out, robots)

    def apply_noise(
        self, z: np.ndarray | None, out: np.ndarray, robots: Sequence[DiffDriveRobot], gains: np.ndarray | None = None
    ) -> None:
        """Gains, then the noise of the standard normals ``z`` ``(k, noise_size)``, on the rows ``out`` of ``robots``.

        ``N(μ, σ²)`` is ``μ + σ z``, as numpy's ``normal`` draws it from the same stream, so a
        robot's ``z`` drawn by itself or in one block with other robots' gives the same values.
        """
        relative = self.relative_noise > 0 and z is not None
        additive = self.noise_std > 0 and z is not None
        if gains is None and self._gains:
            gains = np.stack([self._gains.get(r.name, np.ones(self.width)) for r in robots])
        if not (relative or additive or gains is not None):
            return
        mask = self._noise_mask(out) if (relative or gains is not None) else None
        if gains is not None:
            out[...] = np.where(mask, out * gains, out) if mask is not None else out * gains
        if relative and additive:
            pair = z.reshape(len(out), 2, self.width)
            factor, shift = 1.0 + self.relative_noise * pair[:, 0], self.noise_std * pair[:, 1]
        elif relative:
            factor, shift = 1.0 + (0.0 + self.relative_noise * z), None
        else:
            factor, shift = None, (0.0 + self.noise_std * z) if additive else None
        if factor is not None:
            out[...] = np.where(mask, out * factor, out) if mask is not None else out * factor
        if shift is not None:
            out += shift
        self._clip(out)


class ProximityRing(NoisyRowSensor):
    """Ray-cast distance sensors around the robot's rim.

    A reading is the distance (m) from the robot's surface along the ray to the first solid
    object, or ``max_range`` when nothing is within range. Noise (:class:`NoisyRowSensor`):
    ``relative_noise`` scales the distance of rays that hit something (a Khepera's infrared
    reading falls steeply with distance, so a fixed noise on the reading is a distance error
    growing with distance; a ray that hits nothing stays at ``max_range``); ``noise_std``
    (m) is added to every ray. Readings are clipped to ``[0, max_range]``. Before casting, one bounding-box
    query checks whether anything at all lies within range; if not, the eight casts are
    skipped (they dominate the cost of a simulation step).
    """

    def __init__(
        self,
        angles: Iterable[float] = KHEPERA_RING,
        max_range: float = 0.1,
        noise_std: float = 0.0,
        relative_noise: float = 0.0,
    ) -> None:
        self.angles = np.asarray(list(angles), dtype=float)
        if self.angles.ndim != 1 or len(self.angles) == 0:
            raise ValueError(f"ProximityRing needs at least one ray angle, got {angles!r}")
        if not max_range > 0:
            raise ValueError(f"ProximityRing.max_range must be > 0, got {max_range!r}")
        if not noise_std >= 0:
            raise ValueError(f"ProximityRing.noise_std must be >= 0, got {noise_std!r}")
        self.max_range = float(max_range)
        self._set_noise(noise_std, relative_noise, 0.0)
        self._cos = np.cos(self.angles).tolist()
        self._sin = np.sin(self.angles).tolist()
        self._caster = RayCaster()

    @property
    def n_rays(self) -> int:
        return len(self.angles)

    @property
    def width(self) -> int:
        return len(self.angles)

    def _clip(self, out: np.ndarray) -> None:
        np.clip(out, 0.0, self.max_range, out=out)

    def _noise_mask(self, out: np.ndarray) -> np.ndarray:
        """Relative noise applies to rays that hit something: a free ray reads the sensor's noise floor, beyond range."""
        return out < self.max_range

    def _free_reading(self, out: np.ndarray) -> None:
        out.fill(self.max_range)

    def _read_one(self, robot: DiffDriveRobot, space: pymunk.Space, x: float, y: float, theta: float, out: np.ndarray) -> None:
        """Noise-free distances of one robot into ``out``."""
        out.fill(self.max_range)
        if self._caster.anything_within(space, (x, y), robot.spec.radius + self.max_range, robot.sensor_filter):
            self._cast_one(robot, space, x, y, theta, out)

    def read_many(
        self, spaces: Sequence[pymunk.Space], robots: Sequence[DiffDriveRobot], poses: np.ndarray, out: np.ndarray
    ) -> None:
        """Noise-free distances of robots of several worlds (robot ``m`` in ``spaces[m]``) into the rows of ``out``.

        The readings of :meth:`read_values` robot by robot, bit for bit: the same reach check per
        robot, and the ray ends of every robot with something within reach in one numpy pass with
        the operations of :meth:`_cast_one` (``math``'s cos and sin of the headings, then ``+ − ×``).
        """
        if kernel.enabled():
            _check_shapes(self, robots, poses, out)
            out.fill(self.max_range)
            self._read_many_compiled(spaces, robots, poses, out)
            return
        rows = _check_rows(self, robots, poses, out)
        out.fill(self.max_range)
        caster, span = self._caster, self.max_range
        reach = [
            m
            for m, (robot, space, (x, y, _)) in enumerate(zip(robots, spaces, rows))
            if caster.anything_within(space, (x, y), robot.spec.radius + span, robot.sensor_filter)
        ]
        if not reach:
            return
        radius = np.array([robots[m].spec.radius for m in reach])
        ends = self._ray_ends(poses[reach], radius).ravel().tolist()
        filters = [robots[m].sensor_filter for m in reach]
        distances = caster.ray_distances([spaces[m] for m in reach], ends, filters, len(self._cos), span)
        out[reach] = np.array(distances).reshape(len(reach), len(self._cos))

    def _read_many_compiled(
        self, spaces: Sequence[pymunk.Space], robots: Sequence[DiffDriveRobot], poses: np.ndarray, out: np.ndarray
    ) -> None:
        """:meth:`read_many` through :mod:`teamgym.sim.kernel`: the same Chipmunk queries, made from one compiled loop each."""
        handles, groups, bits, radius, reach_of = self._compiled_targets(spaces, robots)
        near = kernel.shapes_within(handles, groups, bits, np.ascontiguousarray(poses[:, :2]), reach_of)
        reach = np.flatnonzero(near)
        if not len(reach):
            return
        ends = self._ray_ends(poses[reach], radius[reach]).ravel()
        distances = kernel.first_hits(handles[reach], groups[reach], bits[reach], ends, len(self._cos), self.max_range)
        out[reach] = distances.reshape(len(reach), len(self._cos))

    def _compiled_targets(self, spaces: Sequence[pymunk.Space], robots: Sequence[DiffDriveRobot]) -> tuple[np.ndarray, ...]:
        """The spaces' Chipmunk handles, the robots' filter words (group, then category and mask), radii and reaches
        (radius + range); kept while the same spaces and robots are read (a batch reads the same ones every step; a
        robot's sensor filter is fixed when it is made)."""
        memo = self.__dict__.get("_memo")
        same = memo is not None and len(memo[0]) == len(spaces) and len(memo[1]) == len(robots)
        if same and all(map(operator.is_, memo[0], spaces)) and all(map(operator.is_, memo[1], robots)):
            return memo[2]
        handles = kernel.space_handles(spaces)
        words = np.array([kernel.filter_words(robot.sensor_filter) for robot in robots], dtype=np.uint64).reshape(-1, 2)
        radius = np.array([robot.spec.radius for robot in robots])
        targets = (handles, np.ascontiguousarray(words[:, 0]), np.ascontiguousarray(words[:, 1]), radius, radius + self.max_range)
        self._memo = (list(spaces), list(robots), targets)
        return targets

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("_memo", None)  # Chipmunk handles: valid in this process only
        return state

    def _ray_ends(self, picked: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """``(robots, width, 4)``: each ray's ``x0, y0, x1, y1`` from the robots' poses ``picked`` (rows ``x, y, θ, …``)
        and radii, with the operations of :meth:`_cast_one` (``math``'s cos and sin of the headings, then ``+ − ×``)."""
        span = self.max_range
        theta = picked[:, 2]
        c, s = libm(math.cos, theta)[:, None], libm(math.sin, theta)[:, None]
        ca, sa = np.array(self._cos), np.array(self._sin)
        dx, dy = c * ca - s * sa, s * ca + c * sa
        r = radius[:, None]
        start_x, start_y = picked[:, 0, None] + r * dx, picked[:, 1, None] + r * dy
        return np.stack([start_x, start_y, start_x + span * dx, start_y + span * dy], axis=-1)

    def _cast_one(self, robot: DiffDriveRobot, space: pymunk.Space, x: float, y: float, theta: float, out: np.ndarray) -> None:
        """Cast one robot's rays; hits go into ``out`` (the other values are left as they are)."""
        r, span = robot.spec.radius, self.max_range
        c, s = math.cos(theta), math.sin(theta)
        rays = []
        for ca, sa in zip(self._cos, self._sin):
            dx, dy = c * ca - s * sa, s * ca + c * sa
            start_x, start_y = x + r * dx, y + r * dy
            rays.append((start_x, start_y, start_x + span * dx, start_y + span * dy))
        for i, alpha in enumerate(self._caster.cast_rays(space, rays, [robot.sensor_filter] * len(rays))):
            if alpha is not None:
                out[i] = alpha * span


class LightSensor(NoisyRowSensor):
    """Ambient-light intensity per sensor direction towards a point lamp.

    Reading ``i`` is ``I₀ · max(0, cos(φ − α_i)) / max(d, d_min)²`` where ``φ`` is the lamp's
    bearing, ``α_i`` the sensor direction and ``d`` the distance, or 0 when an opaque object
    blocks the line of sight. Boxes are clear plastic (paper 004) and do not block light.
    ``blockers`` is the category mask of what casts shadows (default :data:`OPAQUE`; 0 for a
    lamp that every robot sees from anywhere, as in paper 004, section 2.1).

    ``lamp`` is a point or an entity (a :class:`~teamgym.sim.objects.Lamp`), which the sensor
    then follows when it moves. Noise (:class:`NoisyRowSensor`): per-sensor gains
    (``gain_spread``, drawn by :meth:`~NoisyRowSensor.calibrate`), ``relative_noise`` per
    reading and additive ``noise_std``; readings are clipped at 0 and, with ``saturation``
    (None: none), the sensor saturates: no reading exceeds it, noise and gains included.
    """

    def __init__(
        self,
        lamp: Point | Entity,
        intensity: float = 1.0,
        angles: Iterable[float] = KHEPERA_RING,
        min_distance: float = 0.05,
        noise_std: float = 0.0,
        blockers: int = OPAQUE,
        relative_noise: float = 0.0,
        gain_spread: float = 0.0,
        saturation: float | None = None,
    ) -> None:
        self.lamp = lamp
        self.intensity = float(intensity)
        self.angles = np.asarray(list(angles), dtype=float)
        self.min_distance = float(min_distance)
        self._set_noise(noise_std, relative_noise, gain_spread)
        self.blockers = int(blockers)
        if saturation is not None and not (math.isfinite(saturation) and saturation > 0):
            raise ValueError(f"LightSensor.saturation must be a finite number > 0 or None, got {saturation!r}")
        self.saturation = None if saturation is None else float(saturation)

    @property
    def lamp(self) -> Point:
        """The lamp's position now."""
        return self._lamp_entity.position if self._lamp_entity is not None else self._lamp_point

    @lamp.setter
    def lamp(self, lamp: Point | Entity) -> None:
        if isinstance(lamp, Entity):
            self._lamp_entity: Entity | None = lamp
            self._lamp_point = lamp.position
        else:
            self._lamp_entity = None
            self._lamp_point = (float(lamp[0]), float(lamp[1]))

    @property
    def width(self) -> int:
        return len(self.angles)

    def _clip(self, out: np.ndarray) -> None:
        np.maximum(out, 0.0, out=out)
        if self.saturation is not None:
            np.minimum(out, self.saturation, out=out)

    def _read_one(self, robot: DiffDriveRobot, space: pymunk.Space, x: float, y: float, theta: float, out: np.ndarray) -> None:
        self._shine(robot, space, self.lamp, x, y, theta, out)

    def read_values(
        self, world: World, robots: Sequence[DiffDriveRobot], poses: np.ndarray, out: np.ndarray, free: Sequence[bool] | None
    ) -> None:
        """As :meth:`NoisyRowSensor.read_values`; without shadows (``blockers`` 0) several rows in one numpy pass."""
        if self.blockers or len(robots) < 2:
            super().read_values(world, robots, poses, out, free)
            return
        self.shine_rows(_check_rows(self, robots, poses, out), out)

    def shine_rows(self, poses: Sequence[Sequence[float]], out: np.ndarray) -> None:
        """Noise-free intensities at ``poses`` ``(x, y, θ)`` (nothing shadows) into the rows of ``out``, as :meth:`_shine`."""
        lx, ly = self.lamp
        bearings, gains = [], []
        for x, y, theta in poses:
            bearings.append(math.atan2(ly - y, lx - x) - theta)
            gains.append(self.intensity / max(math.hypot(lx - x, ly - y), self.min_distance) ** 2)
        gain = np.array(gains)[:, None]
        np.maximum(np.cos(np.array(bearings)[:, None] - self.angles) * gain, 0.0, out=out, casting="unsafe")
        if self.saturation is not None and max(gains) > self.saturation:
            over = gain[:, 0] > self.saturation
            out[over] = np.minimum(out[over], self.saturation)

    def shine_array(self, poses: np.ndarray, out: np.ndarray) -> None:
        """:meth:`shine_rows` of the rows ``(x, y, θ, …)`` of an array, element-wise ``math`` (:func:`libm`): the same bits."""
        lx, ly = self.lamp
        dx, dy = lx - poses[:, 0], ly - poses[:, 1]
        bearings = libm(math.atan2, dy, dx) - poses[:, 2]
        gains = self.intensity / libm(math.pow, np.maximum(libm(math.hypot, dx, dy), self.min_distance), np.full(len(dx), 2.0))
        gain = gains[:, None]
        np.maximum(np.cos(bearings[:, None] - self.angles) * gain, 0.0, out=out, casting="unsafe")
        if self.saturation is not None and len(gains) and gains.max() > self.saturation:
            over = gains > self.saturation
            out[over] = np.minimum(out[over], self.saturation)

    def _shine(
        self, robot: DiffDriveRobot, space: pymunk.Space, lamp: Point, x: float, y: float, theta: float, out: np.ndarray
    ) -> None:
        """Noise-free intensities of one robot into ``out``."""
        lx, ly = lamp
        d = math.hypot(lx - x, ly - y)
        blocked = False
        if self.blockers and d > 1e-9:
            query_filter = pymunk.ShapeFilter(group=robot.group, mask=self.blockers)
            blocked = space.segment_query_first((x, y), lamp, 0.0, query_filter) is not None
        if blocked:
            out.fill(0.0)
        else:
            bearing = math.atan2(ly - y, lx - x) - theta
            gain = self.intensity / max(d, self.min_distance) ** 2
            np.maximum(np.cos(bearing - self.angles) * gain, 0.0, out=out, casting="unsafe")
            if self.saturation is not None and gain > self.saturation:
                np.minimum(out, self.saturation, out=out)


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

    As rows (:meth:`read_rows`), the camera reports, for each kind in the order given by
    ``kinds``, its ``slots`` nearest sightings as ``(1, distance, bearing)``, nearest
    first, and ``(0, 0, 0)`` for every slot left empty: ``width = 3 · slots · len(kinds)``.
    """

    def __init__(
        self,
        fov: float = math.radians(60.0),
        max_range: float = 0.5,
        kinds: Iterable[Category] = (Category.ROBOT, Category.BOX, Category.TARGET, Category.OBSTACLE),
        occlusion: bool = True,
        slots: int = 1,
    ) -> None:
        if not 0 < fov <= 2 * math.pi:
            raise ValueError(f"Camera.fov must be in (0, 2π], got {fov!r}")
        if not max_range > 0:
            raise ValueError(f"Camera.max_range must be > 0, got {max_range!r}")
        if not (isinstance(slots, int) and slots >= 1):
            raise ValueError(f"Camera.slots must be an int >= 1, got {slots!r}")
        self.fov = float(fov)
        self.max_range = float(max_range)
        #: The kinds seen, in row order.
        self.kind_order = tuple(dict.fromkeys(Category(k) for k in kinds))
        self.kinds = frozenset(self.kind_order)
        self.occlusion = occlusion
        self.slots = slots

    @property
    def width(self) -> int:
        return 3 * self.slots * len(self.kind_order)

    def read(
        self,
        robot: DiffDriveRobot,
        entities: Iterable[Entity],
        space: pymunk.Space,
        pose: tuple[float, float, float] | None = None,
    ) -> list[Sighting]:
        """What ``robot`` sees of ``entities``; ``pose`` may give its ``(x, y, θ)`` if already read."""
        x, y, theta = pose if pose is not None else robot.pose
        return self._see(robot, entities, space, x, y, theta)

    def read_rows(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        rng: np.random.Generator | None,
        out: np.ndarray,
    ) -> None:
        """Nearest sightings per kind (see the class docstring); the camera has no noise."""
        entities, space = list(world.entities.values()), world.space
        column = {kind: 3 * self.slots * i for i, kind in enumerate(self.kind_order)}
        for robot, (x, y, theta), row in zip(robots, _check_rows(self, robots, poses, out), out):
            row.fill(0.0)
            filled = dict.fromkeys(self.kind_order, 0)
            for sighting in sorted(self._see(robot, entities, space, x, y, theta), key=lambda s: s.distance):
                slot = filled[sighting.kind]
                if slot < self.slots:
                    start = column[sighting.kind] + 3 * slot
                    row[start : start + 3] = (1.0, sighting.distance, sighting.bearing)
                    filled[sighting.kind] = slot + 1

    def _see(
        self, robot: DiffDriveRobot, entities: Iterable[Entity], space: pymunk.Space, x: float, y: float, theta: float
    ) -> list[Sighting]:
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


class WheelEncoders:
    """The wheel encoders' last control step: commanded left, commanded right, actual left,
    actual right wheel rotation (rad), from :attr:`DiffDriveRobot.encoders`.

    The commanded values are exact (what the motors were asked). With ``resolution`` > 0
    (rad per tick) the actual rotation is what an incremental encoder counts: the difference
    of the tick counts of the total wheel rotation before and after the step (the error
    stays under one tick and does not accumulate). With ``noise_std`` > 0 it is then
    multiplied by ``1 + N(0, noise_std²)`` per wheel (the wheel slips a little on the
    table; two draws per robot). Both 0: the exact rotation, as before. With ``saturation``
    (rad; None: none) every value is clipped to ``[-saturation, saturation]``: the counter
    reads at most that many radians per step.
    """

    width = 4

    def __init__(self, noise_std: float = 0.0, resolution: float = 0.0, saturation: float | None = None) -> None:
        for key, value in (("noise_std", noise_std), ("resolution", resolution)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"WheelEncoders.{key} must be a finite number >= 0, got {value!r}")
        if saturation is not None and not (math.isfinite(saturation) and saturation > 0):
            raise ValueError(f"WheelEncoders.saturation must be a finite number > 0 or None, got {saturation!r}")
        self.noise_std = float(noise_std)
        self.resolution = float(resolution)
        self.saturation = None if saturation is None else float(saturation)

    def read_rows(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        rng: np.random.Generator | None,
        out: np.ndarray,
    ) -> None:
        size = self.noise_size if rng is not None else 0
        self.read_drawn(world, robots, poses, rng.standard_normal((len(robots), size)) if size else None, out)

    @property
    def noise_size(self) -> int:
        """Standard normals drawn per robot: one per wheel when ``noise_std`` > 0."""
        return 2 if self.noise_std > 0 else 0

    def read_drawn(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        z: np.ndarray | None,
        out: np.ndarray,
        gains: np.ndarray | None = None,
    ) -> None:
        """:meth:`read_rows` with the noise's standard normals given: ``z`` ``(k, 2)`` (``None``: no noise; no gains)."""
        if out.shape != (len(robots), self.width):
            raise ValueError(f"WheelEncoders.read_rows: out must have shape {(len(robots), self.width)}, got {out.shape}")
        res = self.resolution
        factors = (1.0 + self.noise_std * z).tolist() if z is not None and self.noise_std > 0 else None
        for j, (robot, row) in enumerate(zip(robots, out)):
            commanded_left, commanded_right, left, right, total_left, total_right = robot.encoder_row
            if res > 0:
                left = (math.floor(total_left / res) - math.floor((total_left - left) / res)) * res
                right = (math.floor(total_right / res) - math.floor((total_right - right) / res)) * res
            if factors is not None:
                a, b = factors[j]
                left, right = left * a, right * b
            values = (commanded_left, commanded_right, left, right)
            top = self.saturation
            if top is not None and max(map(abs, values)) > top:
                values = tuple(min(max(v, -top), top) for v in values)
            row[:] = values

    def read_raw(self, raw: np.ndarray, z: np.ndarray | None, out: np.ndarray) -> None:
        """:meth:`read_drawn` of robots whose :attr:`DiffDriveRobot.encoder_row` are the rows of ``raw`` ``(k, 6)``.

        One numpy pass over all robots (for a batch's many robots; a few cost less robot by
        robot), the same bits as :meth:`read_drawn`: ticks (``resolution``), then the factors
        ``1 + noise_std z`` per wheel, then the clip at ``saturation``.
        """
        out[:, 0:2] = raw[:, 0:2]
        actual = raw[:, 2:4]
        if self.resolution > 0:
            res, totals = self.resolution, raw[:, 4:6]
            # + 0.0: the per-robot form subtracts math.floor's ints, whose difference 0 is never −0.0
            actual = ((np.floor(totals / res) - np.floor((totals - actual) / res)) + 0.0) * res
        if z is not None and self.noise_std > 0:
            actual = actual * (1.0 + self.noise_std * z)
        out[:, 2:4] = actual
        if self.saturation is not None:
            top = self.saturation
            values = np.concatenate([raw[:, 0:2], actual], axis=1)
            np.clip(values, -top, top, out=values)
            out[:] = values


def encoder_rows(robots: Sequence[DiffDriveRobot]) -> np.ndarray:
    """``(k, 6)``: each robot's :attr:`~teamgym.sim.robot.DiffDriveRobot.encoder_row` (float64)."""
    return np.array([robot.encoder_row for robot in robots], dtype=float).reshape(len(robots), 6)


class SensorSuite:
    """Several named sensors read into one row per robot, side by side in the order given.

    :meth:`read_rows` reads robot after robot and, for each robot, sensor after sensor: the
    noise draws come in that order (as in an env that reads every sensor of a robot before
    the next robot). ``slices[name]`` are the columns of sensor ``name``.
    """

    def __init__(self, sensors: Mapping[str, Sensor]) -> None:
        if not sensors:
            raise ValueError("SensorSuite needs at least one sensor")
        self.sensors = dict(sensors)
        self.slices: dict[str, slice] = {}
        start = 0
        for name, sensor in self.sensors.items():
            self.slices[name] = slice(start, start + sensor.width)
            start += sensor.width
        self.width = start
        self._parts = [(sensor, self.slices[name]) for name, sensor in self.sensors.items()]

    def read_rows(
        self,
        world: World,
        robots: Sequence[DiffDriveRobot],
        poses: np.ndarray,
        rng: np.random.Generator | None,
        out: np.ndarray,
        gains: Mapping[str, np.ndarray] | None = None,
    ) -> None:
        """The rows of every sensor; ``gains`` (optional): per sensor name, the robots' gains ``(k, width)``."""
        _check_rows(self, robots, poses, out)
        parts = self._parts
        if all(hasattr(sensor, "read_drawn") for sensor, _ in parts):
            # Every robot's noise in one block, robot after robot and sensor after sensor: the
            # stream the loop below would draw, so the readings are the same.
            sizes = [sensor.noise_size if rng is not None else 0 for sensor, _ in parts]
            z = rng.standard_normal((len(robots), sum(sizes))) if sum(sizes) else None
            start = 0
            for (name, sensor), (_, columns), size in zip(self.sensors.items(), parts, sizes):
                drawn = z[:, start : start + size] if size else None
                sensor.read_drawn(world, robots, poses, drawn, out[:, columns], None if gains is None else gains.get(name))
                start += size
            return
        if gains:
            raise ValueError("SensorSuite.read_rows: gains are passed only to sensors with read_drawn")
        for j, robot in enumerate(robots):
            one, pose, row = [robot], poses[j : j + 1], out[j : j + 1]
            for sensor, columns in parts:
                sensor.read_rows(world, one, pose, rng, row[:, columns])
