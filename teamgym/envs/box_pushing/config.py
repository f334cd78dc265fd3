"""Configuration of ``BoxPushing-v0``: keys, defaults, situation presets and scheduled events.

Every default is explained in ``docs/box_pushing.md``; the physical ones are chosen so that
"light" and "heavy" follow from box mass and ground friction against the motors' force
limit (paper 004, section 2.2): one robot slides a light box, cannot move a heavy one (not
even turn it by pushing a corner), and two robots pushing together can.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from teamgym.envs.bounds import Limit, require_limits, require_ring_noise
from teamgym.envs.config import ConfigError, EnvConfig, require, require_together
from teamgym.sim.objects import GRAVITY, SURFACE_FRICTION, footprint_support, weakest_push
from teamgym.sim.robot import RobotSpec

#: The paper's four static situations (section 4.1) as (n_robots, n_light_boxes, n_heavy_boxes).
SITUATIONS: dict[str, tuple[int, int, int]] = {
    "S1": (1, 1, 0),
    "S2": (2, 2, 0),
    "S3": (4, 0, 1),
    "S4": (1, 0, 1),
}

#: Scheduled event kinds and the arguments they take after ``(cycle, kind)``.
EVENT_KINDS = {
    "add_robot": "optional x, y[, heading] (m, rad)",
    "remove_robot": "agent name",
    "break_down": "agent name",
    "add_light_box": "optional x, y[, angle] (m, rad)",
    "add_heavy_box": "optional x, y[, angle] (m, rad)",
    "remove_box": "box name",
}


@dataclass(frozen=True)
class Event:
    """A run-time change applied at the end of control step ``cycle`` (after the physics)."""

    cycle: int
    kind: str
    args: tuple


@functools.lru_cache(maxsize=32)
def weakest_push_ratio(table_friction: str, support_points: int) -> float:
    """The weakest single push that moves a square box on support points, in units of ``μ m g``.

    :func:`~teamgym.sim.objects.weakest_push` for a robot (``RobotSpec.friction``) against a
    box surface (``SURFACE_FRICTION``); the ratio does not depend on the box's size or mass.
    """
    points = footprint_support((1.0, 1.0), table_friction, support_points)
    return weakest_push(points, (1.0, 1.0), RobotSpec.friction * SURFACE_FRICTION)


@dataclass(frozen=True)
class BoxPushingConfig(EnvConfig):
    """Configuration of ``BoxPushing-v0`` (SI units; the few angles in config are radians).

    Keys that scale a sensor reading have ranges (``READING_LIMITS``; ``docs/box_pushing.md``,
    *Sensor ranges and saturation*): ``noise`` [0, 10]; ``light_noise`` [0, 10] light units
    (the sensor saturates at 1000, the brightest noise-free reading is 400); the relative
    noises, ``light_gain_spread``, ``encoder_noise`` and ``motor_noise`` [0, 1];
    ``sensor_range`` and ``sensor_noise`` [0, 10] m; ``encoder_resolution`` [0, π/4] rad;
    ``max_wheel_speed`` (0, 10] m/s. Scaled by ``noise``, a noise level must stay in its range
    and the proximity noise at most ``sensor_range``.
    """

    body_speed_keys: ClassVar[tuple[str, ...]] = ("max_wheel_speed",)
    default_body_speed: ClassVar[float] = 0.0
    #: The noise levels that ``noise`` scales.
    NOISE_KEYS: ClassVar[tuple[str, ...]] = (
        "light_noise",
        "light_noise_relative",
        "light_gain_spread",
        "sensor_noise",
        "sensor_noise_relative",
        "encoder_noise",
        "motor_noise",
    )
    #: Own ranges of the keys that scale a sensor reading (``docs/box_pushing.md``, *Sensor ranges
    #: and saturation*); a noise level scaled by ``noise`` must hold its range too (``check_relations``).
    READING_LIMITS: ClassVar[dict[str, Limit]] = {
        "noise": (0.0, 10.0, ""),
        "light_noise": (0.0, 10.0, "(light units; 1 at 1 m from the lamp)"),
        "light_noise_relative": (0.0, 1.0, ""),
        "light_gain_spread": (0.0, 1.0, ""),
        "sensor_range": (0.0, 10.0, "m"),
        "sensor_noise": (0.0, 10.0, "m"),
        "sensor_noise_relative": (0.0, 1.0, ""),
        "encoder_noise": (0.0, 1.0, ""),
        "encoder_resolution": (0.0, math.pi / 4, "rad (8 ticks per wheel turn)"),
        "motor_noise": (0.0, 1.0, ""),
        "max_wheel_speed": (0.0, 10.0, "m/s"),
    }

    max_cycles: int = 6000
    situation: Literal["custom", "S1", "S2", "S3", "S4"] = "custom"
    n_robots: int = 2
    n_light_boxes: int = 2
    n_heavy_boxes: int = 0
    n_spare_robots: int = 0
    n_spare_boxes: int = 0
    table_width: float = 1.10
    table_height: float = 0.90
    lamp: tuple[float, float] = (1.15, 0.45)
    light_shadows: bool = False
    observe_stall: bool = False
    noise: float = 1.0
    light_noise: float = 0.0
    light_noise_relative: float = 0.0
    light_gain_spread: float = 0.0
    sensor_range: float = 0.1
    sensor_noise: float = 0.0
    sensor_noise_relative: float = 0.0
    encoder_noise: float = 0.0
    encoder_resolution: float = 0.0
    motor_noise: float = 0.0
    object_threshold: float = 0.02
    max_wheel_speed: float = 0.4
    max_motor_force: float = 0.6
    light_box_size: float = 0.08
    light_box_mass: float = 0.05
    heavy_box_size: float = 0.16
    heavy_box_mass: float = 0.2
    box_friction: float = 0.5
    table_friction: Literal["joint", "corners", "perimeter", "area"] = "joint"
    support_points: int = 3
    box_margin: float = 0.08
    box_orientation: Literal["aligned", "random"] = "random"
    boxes_to_goal: int = 0
    goal_tolerance: float = 0.003
    action_type: Literal["primitives", "wheels"] = "primitives"
    cruise_speed: float = 0.2
    push_speed: float = 0.08
    follow_speed: float = 0.1
    turn_rate: float = 5.0
    turn_step: float = math.radians(30.0)
    direction_change_jitter: float = math.radians(30.0)
    side_offset: float = 0.07
    follow_step: float = 0.01
    progress_reward: float = 10.0
    success_bonus: float = 10.0
    time_penalty: float = 0.001
    events: tuple[tuple[Any, ...], ...] = ()

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> BoxPushingConfig:
        """As :meth:`EnvConfig.from_kwargs`; ``situation="S1"``..``"S4"`` presets the robot and box counts."""
        name = kwargs.get("situation", "custom")
        if isinstance(name, str) and name in SITUATIONS:
            for key, value in zip(("n_robots", "n_light_boxes", "n_heavy_boxes"), SITUATIONS[name]):
                given = kwargs.get(key, value)
                if given != value and str(given) != str(value):
                    raise ConfigError(
                        f"{cls.__name__}: {key}={given!r} contradicts situation={name!r} (which sets {key}={value})"
                    )
                kwargs[key] = value
        return super().from_kwargs(**kwargs)  # type: ignore[return-value]

    def check(self) -> None:
        super().check()
        require(self, "n_robots", 1 <= self.n_robots <= 16, "must be in [1, 16]")
        require(self, "n_light_boxes", 0 <= self.n_light_boxes <= 8, "must be in [0, 8]")
        require(self, "n_heavy_boxes", 0 <= self.n_heavy_boxes <= 8, "must be in [0, 8]")
        require(self, "n_spare_robots", 0 <= self.n_spare_robots <= 16, "must be in [0, 16]")
        require(self, "n_spare_boxes", 0 <= self.n_spare_boxes <= 8, "must be in [0, 8]")
        require(self, "support_points", 1 <= self.support_points <= 16, "must be in [1, 16]")
        require(self, "table_width", 0.4 <= self.table_width <= 10, "must be in [0.4, 10] m")
        require(self, "table_height", 0.4 <= self.table_height <= 10, "must be in [0.4, 10] m")
        for key in ("sensor_range", "object_threshold", "max_wheel_speed", "max_motor_force", "box_friction"):
            require(self, key, getattr(self, key) > 0, "must be > 0")
        non_negative = ("noise", *self.NOISE_KEYS, "encoder_resolution", "box_margin", "goal_tolerance")
        non_negative += ("time_penalty", "success_bonus")
        for key in non_negative:
            require(self, key, getattr(self, key) >= 0, "must be >= 0")
        require_limits(self, self.READING_LIMITS)
        for key in ("cruise_speed", "push_speed", "follow_speed", "turn_rate", "turn_step"):
            require(self, key, getattr(self, key) > 0, "must be > 0")
        require(self, "direction_change_jitter", 0 <= self.direction_change_jitter <= math.pi / 2, "must be in [0, π/2] rad")
        require(self, "side_offset", 0 < self.side_offset <= 0.5, "must be in (0, 0.5] m")
        require(self, "follow_step", 0 < self.follow_step <= 0.5, "must be in (0, 0.5] m")
        for kind in ("light", "heavy"):
            require(self, f"{kind}_box_size", 0.03 <= getattr(self, f"{kind}_box_size") <= 0.4, "must be in [0.03, 0.4] m")
            require(self, f"{kind}_box_mass", getattr(self, f"{kind}_box_mass") > 0, "must be > 0")
        require(self, "boxes_to_goal", 0 <= self.boxes_to_goal <= 24, "must be in [0, 24] (0 = every box)")

    def check_relations(self) -> None:
        super().check_relations()
        self._check_noise_levels()
        if self.situation in SITUATIONS:
            for key, value in zip(("n_robots", "n_light_boxes", "n_heavy_boxes"), SITUATIONS[self.situation]):
                require_together(
                    self, (key, "situation"), getattr(self, key) == value, f"situation={self.situation!r} sets {key}={value}"
                )
        require_together(
            self, ("n_light_boxes", "n_heavy_boxes"), self.n_light_boxes + self.n_heavy_boxes >= 1, "they leave no box (need one)"
        )
        require_together(
            self,
            ("object_threshold", "sensor_range"),
            self.object_threshold <= self.sensor_range,
            "object_threshold must not exceed sensor_range",
        )
        for key in ("cruise_speed", "push_speed", "follow_speed"):
            require_together(
                self,
                (key, "max_wheel_speed"),
                getattr(self, key) <= self.max_wheel_speed,
                f"{key} must not exceed max_wheel_speed",
            )
        half_base = 0.053 / 2
        require_together(
            self,
            ("turn_rate", "max_wheel_speed"),
            self.turn_rate * half_base <= self.max_wheel_speed,
            "turn_rate must be in (0, 2·max_wheel_speed/wheel_base]",
        )
        require_together(
            self,
            ("turn_step", "dt", "max_wheel_speed"),
            self.turn_step / self.dt * half_base <= self.max_wheel_speed,
            "turn_step must be turnable in one step",
        )
        self._check_boxes()
        self._check_lamp()
        self.parsed_events()
        total = self.n_light_boxes + self.n_heavy_boxes + self.n_spare_boxes
        require_together(
            self,
            ("boxes_to_goal", "n_light_boxes", "n_heavy_boxes", "n_spare_boxes"),
            self.boxes_to_goal <= total,
            f"boxes_to_goal must be in [0, {total}] (0 = every box)",
        )

    def _check_noise_levels(self) -> None:
        """Every noise level scaled by ``noise`` holds its range (the proximity noise also stays below the range)."""
        for key in self.NOISE_KEYS:
            level, top = self.noise_level(key), self.READING_LIMITS[key][1]
            require_together(self, ("noise", key), level <= top, f"noise × {key} = {level:g} must not exceed {top:g}")
        require_ring_noise(self, self.noise_level("sensor_noise"), ("noise", "sensor_noise", "sensor_range"))

    def _check_boxes(self) -> None:
        """Light and heavy as paper 004 defines them: one robot slides a light box; a heavy box needs two."""
        force = self.max_motor_force
        light = self.box_friction * self.light_box_mass * GRAVITY
        heavy = self.box_friction * self.heavy_box_mass * GRAVITY
        require_together(
            self,
            ("light_box_mass", "box_friction", "max_motor_force"),
            light < 0.9 * force,
            f"a light box's friction box_friction·light_box_mass·g = {light:.2f} N must be below 0.9·max_motor_force "
            f"({0.9 * force:.2f} N): one robot must slide it",
        )
        require_together(
            self,
            ("heavy_box_mass", "box_friction", "max_motor_force"),
            force < heavy < 2 * force,
            f"a heavy box's friction box_friction·heavy_box_mass·g = {heavy:.2f} N must be in ({force}, {2 * force}) N:"
            " one robot must not move it and two must",
        )
        if self.table_friction == "joint":
            # A robot pushing a corner exerts torque F·s/2; the ground's torque limit is μmg·⅔·r_eq (objects.Box).
            r_eq = math.sqrt(self.heavy_box_size**2 / math.pi)
            require_together(
                self,
                ("heavy_box_mass", "heavy_box_size", "box_friction", "max_motor_force"),
                heavy * 2 / 3 * r_eq > force * self.heavy_box_size / 2,
                "they let one robot spin the heavy box at a corner",
            )
        else:
            weakest = heavy * weakest_push_ratio(self.table_friction, self.support_points)
            require_together(
                self,
                ("heavy_box_mass", "box_friction", "max_motor_force", "table_friction", "support_points"),
                weakest > force,
                f"they let one robot turn the heavy box at a corner ({weakest:.2f} N of friction there, {force} N of force)",
            )

    def _check_lamp(self) -> None:
        x, y = self.lamp
        w, h = self.table_width, self.table_height
        keys = ("lamp", "table_width", "table_height")
        inside = 0 <= x <= w and 0 <= y <= h
        require_together(self, keys, not inside, "the lamp must be outside the table (beside it, paper 004 section 2.1)")
        require_together(self, keys, -1 <= x <= w + 1 and -1 <= y <= h + 1, "the lamp must be within 1 m of the table")
        outside = sorted(gap for gap in (x - w, -x, y - h, -y) if gap > 0)
        require_together(self, keys, len(outside) == 1, "the lamp must face one wall (the goal), not a corner of the table")

    def noise_level(self, key: str) -> float:
        """The noise level ``key`` in effect: the config's value times the ``noise`` scale."""
        if key not in self.NOISE_KEYS:
            raise KeyError(f"{key!r} is not a noise level; noise levels are {self.NOISE_KEYS}")
        return self.noise * float(getattr(self, key))

    @property
    def effective_encoder_resolution(self) -> float:
        """``encoder_resolution`` when ``noise`` > 0, else 0 (exact encoders)."""
        return self.encoder_resolution if self.noise > 0 else 0.0

    def goal_side(self) -> str:
        """The wall nearest the lamp: ``"east"``, ``"west"``, ``"north"`` or ``"south"``."""
        x, y = self.lamp
        w, h = self.table_width, self.table_height
        gaps = {"east": x - w, "west": -x, "north": y - h, "south": -y}
        return max(gaps, key=lambda k: gaps[k])

    def parsed_events(self) -> list[Event]:
        """The scheduled events as :class:`Event` records, validated (raises :class:`ConfigError`)."""
        events = []
        added_robots = added_boxes = 0
        for raw in self.events:
            where = f"{type(self).__name__}: events entry {raw!r}"
            if len(raw) < 2 or not isinstance(raw[0], int) or isinstance(raw[0], bool) or raw[1] not in EVENT_KINDS:
                raise ConfigError(f"{where} must be (cycle, kind, *args) with kind in {sorted(EVENT_KINDS)}")
            cycle, kind, args = raw[0], raw[1], tuple(raw[2:])
            if not 1 <= cycle <= self.max_cycles:
                raise ConfigError(f"{where}: cycle {cycle} must be in [1, max_cycles={self.max_cycles}]")
            if kind in ("remove_robot", "break_down", "remove_box"):
                if len(args) != 1 or not isinstance(args[0], str):
                    raise ConfigError(f"{where}: {kind} takes one argument, the {EVENT_KINDS[kind]}")
            else:
                if len(args) not in (0, 2, 3) or not all(isinstance(a, (int, float)) and math.isfinite(a) for a in args):
                    raise ConfigError(f"{where}: {kind} takes {EVENT_KINDS[kind]}")
                if args and not (0 < args[0] < self.table_width and 0 < args[1] < self.table_height):
                    raise ConfigError(f"{where}: position {args[:2]} is not on the table")
                if kind == "add_robot":
                    added_robots += 1
                else:
                    added_boxes += 1
            events.append(Event(cycle, kind, tuple(float(a) if isinstance(a, (int, float)) else a for a in args)))
        if added_robots > self.n_spare_robots:
            raise ConfigError(
                f"{type(self).__name__}: events add {added_robots} robot(s) but n_spare_robots={self.n_spare_robots}"
            )
        if added_boxes > self.n_spare_boxes:
            raise ConfigError(f"{type(self).__name__}: events add {added_boxes} box(es) but n_spare_boxes={self.n_spare_boxes}")
        return sorted(events, key=lambda e: e.cycle)


#: Encoder resolution of a Khepera: 600 ticks per wheel turn (rad per tick).
KHEPERA_ENCODER_RESOLUTION = 2 * math.pi / 600


@dataclass(frozen=True)
class BoxPushingV1Config(BoxPushingConfig):
    """Configuration of ``BoxPushing-v1``: ``BoxPushing-v0``'s keys with a truthful table and Khepera-like noise.

    Only defaults differ (``docs/box_pushing.md``, *Version history*): boxes stand on their
    four corners and robots on their two wheels, each point with its own Coulomb friction
    (``table_friction="corners"``), so an off-centre push turns a sliding box; and the
    sensors and motors are noisy (``noise=0`` switches every noise off):

    * proximity: ``sensor_noise_relative=0.05`` (5 % of the distance, rays that hit something);
    * light: ``light_noise_relative=0.1`` per reading (Webots' Khepera model) and
      ``light_gain_spread=0.2`` (each sensor's own sensitivity, log-normal, fixed per robot);
    * encoders: Khepera ticks (600 per wheel turn) and ``encoder_noise=0.04`` per wheel;
    * motors: ``motor_noise=0.06`` per wheel and step (Webots' ±10 % uniform slip noise).
    """

    table_friction: Literal["joint", "corners", "perimeter", "area"] = "corners"
    light_noise_relative: float = 0.1
    light_gain_spread: float = 0.2
    sensor_noise_relative: float = 0.05
    encoder_noise: float = 0.04
    encoder_resolution: float = KHEPERA_ENCODER_RESOLUTION
    motor_noise: float = 0.06
