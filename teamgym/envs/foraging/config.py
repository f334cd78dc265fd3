"""Configuration of ``Foraging-v0`` (paper 002): the field, the robots, perception and the task."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Literal

from teamgym.envs.config import EnvConfig, require, require_together
from teamgym.envs.foraging.grid import GridSpec
from teamgym.sim.robot import RobotSpec

__all__ = ["DERIVED_CYCLES_CAP", "ForagingConfig"]

#: The most control steps an episode derived from ``time_limit`` may last (``max_cycles=None``).
DERIVED_CYCLES_CAP = 10**6


@dataclass(frozen=True)
class ForagingConfig(EnvConfig):
    """Configuration of ``Foraging-v0`` (SI units, angles in rad).

    Task (section 4.1): ``task="consume"``: a target disappears once one robot has stayed
    within ``reach_radius`` of it for ``consume_time`` s; success when every target is
    consumed. ``task="surround"``: a target is done when ``robots_per_target`` robots are
    within ``reach_radius`` of it at once; success when every target is done. An episode
    lasts at most ``time_limit`` s: :attr:`cycle_limit` = ⌈``time_limit`` / ``dt``⌉ control
    steps (2,000 by default), at most 10⁶. ``max_cycles`` is ``None`` by default (the length
    derives from ``time_limit``); an int caps the control steps as well (the smaller limit
    applies).

    Field (section 4.3): a walled ``field_size`` rectangle (the RoboCup small-size field,
    3.0 m × 2.4 m) with a world-model grid of ``cell_size`` cells; landmarks every
    ``landmark_spacing`` m along the walls (corners included).

    Robots (section 4.2, the Viper): ``robot_radius``, ``max_speed`` (m/s), a forward camera of
    ``camera_range`` (1 m) and opening ``camera_fov``. The default opening, 1.28 rad (73°),
    makes the camera's sector cover 16 cells of 0.2 m, the paper's "perception limited to 16
    cells in the direction of the robot's heading" (area ``fov / 2 · range²`` = 0.64 m²).

    Perception uncertainty (section 2.2): ``vision_noise`` scales the measurement errors of
    the look-up table in :mod:`teamgym.envs.foraging.perception` (0: exact vision);
    ``rotational_certainty`` is Pe of eq. (2) (certainty kept per radian turned);
    ``odometry_rotation_noise`` is the heading error (rad) per radian turned and
    ``odometry_distance_noise`` the position error (m) per metre travelled (0 and 0: exact
    odometry). Ranges: ``vision_noise`` [0, 10] (σ_d up to 1.5 m, σ_b up to 1 rad; measured
    distances saturate at ``camera_range`` + 1 m, bearings wrap to [−π, π]), the odometry
    noises [0, 1].

    Consumed targets (``consume``; the paper does not say what becomes of one):
    ``consumed_targets="vanish"`` (default) removes a consumed target from the world and from
    every camera, so a robot sees that a teammate has consumed it. ``"persist"`` keeps it where
    it was and in every camera, as a target like any other: the Viper's colour-coded vision
    cannot tell a consumed target from a live one (section 2: implicit communication "requires
    expensive resolution and recognition"), so a robot learns of a teammate's consumption only
    by radio, and without it "two robots can redundantly approach and consume the same target"
    (section 5.1). A consumed target cannot be consumed again; a robot that stays
    ``consume_time`` at it completes its own (redundant) operation — ``consume_progress``
    reaches 1 and stays 1 while it is within reach — and nothing else happens.

    Radio rate: ``packet_rate`` (packets per second each robot broadcasts, in [0, 1/``dt``]);
    ``None`` (default) sends one every control step (1/``dt``, 10 per s). A rate r sends at the
    control steps k where ⌊k·r·dt⌋ steps up (step 0, at reset, included for r > 0): evenly
    spaced, no random draw. ``comm_throughput`` still drops each copy with probability
    1 − throughput, so the robots receive ``packet_rate × comm_throughput`` packets per second.

    Observation options (for learned policies; scripted ones ignore them):
    ``observe_world_model`` adds the robot's fused grid world model (targets, robots);
    ``observe_novelty`` adds, per cell, ``1 − exp(−age / novelty_time)`` where ``age`` is the
    time since the robot's world model last saw the cell (never seen: 1) — the novelty term of
    DMAPS's search field (``novelty_time`` 30 s as its ``FieldParams``), which the world model
    alone does not show. ``world_model_sources`` says what those two layers are built from:
    ``"all"`` (default) the robot's own sightings and every packet it received (dmaps's model),
    ``"own"`` its own sightings only (the model of ``dmaps-nocomm``, which ignores the radio; the
    ``received`` tuples stay in the observation).
    """

    body_speed_keys: ClassVar[tuple[str, ...]] = ("max_speed",)
    cycle_limit_keys: ClassVar[tuple[str, ...]] = ("max_cycles", "time_limit", "dt")
    default_body_speed: ClassVar[float] = 0.0

    max_cycles: int | None = None
    substeps: int = 10
    task: Literal["consume", "surround"] = "consume"
    n_robots: int = 2
    n_targets: int = 3
    robots_per_target: int = 2
    consume_time: float = 10.0
    time_limit: float = 200.0
    field_size: tuple[float, float] = (3.0, 2.4)
    cell_size: float = 0.2
    landmark_spacing: float = 0.6
    robot_radius: float = 0.09
    max_speed: float = 0.5
    reach_radius: float = 0.2
    camera_range: float = 1.0
    camera_fov: float = 1.28
    vision_noise: float = 1.0
    rotational_certainty: float = 0.9
    odometry_rotation_noise: float = 0.05
    odometry_distance_noise: float = 0.01
    action_type: Literal["goto_cell", "velocity"] = "goto_cell"
    observe_world_model: bool = False
    observe_novelty: bool = False
    world_model_sources: Literal["all", "own"] = "all"
    novelty_time: float = 30.0
    consume_reward: float = 1.0
    progress_reward: float = 0.01
    time_penalty: float = 0.001
    consumed_targets: Literal["vanish", "persist"] = "vanish"
    packet_rate: float | None = None

    def check(self) -> None:
        super().check()  # max_cycles=None (derived from time_limit) passes EnvConfig's range check
        width, height = self.field_size
        require(self, "field_size", 0.5 <= width <= 50 and 0.5 <= height <= 50, "must be (width, height) in [0.5, 50] m")
        require(self, "n_robots", 1 <= self.n_robots <= 16, "must be in [1, 16]")
        require(self, "n_targets", 1 <= self.n_targets <= 32, "must be in [1, 32]")
        require(self, "robots_per_target", 1 <= self.robots_per_target <= 16, "must be in [1, 16]")
        require(self, "consume_time", 0 < self.consume_time <= 100_000, "must be in (0, 100000] s")
        require(self, "time_limit", 0 < self.time_limit <= 100_000, "must be in (0, 100000] s")
        require(self, "cell_size", 0.05 <= self.cell_size <= 25, "must be in [0.05, 25] m")
        require(self, "landmark_spacing", 0.1 <= self.landmark_spacing <= 200, "must be in [0.1, 200] m")
        require(self, "robot_radius", 0.02 <= self.robot_radius <= 0.5, "must be in [0.02, 0.5] m")
        require(self, "max_speed", 0.01 <= self.max_speed <= 5, "must be in [0.01, 5] m/s")
        require(self, "reach_radius", 0.02 <= self.reach_radius <= 2.0, "must be in [0.02, 2] m")
        require(self, "camera_range", 0.1 <= self.camera_range <= 100, "must be in [0.1, 100] m")
        require(self, "camera_fov", 0.05 <= self.camera_fov <= 2 * math.pi, "must be in [0.05, 2π] rad")
        require(self, "vision_noise", 0 <= self.vision_noise <= 10, "must be in [0, 10]")
        require(self, "rotational_certainty", 0 < self.rotational_certainty <= 1, "must be in (0, 1]")
        require(self, "odometry_rotation_noise", 0 <= self.odometry_rotation_noise <= 1, "must be in [0, 1] rad/rad")
        require(self, "odometry_distance_noise", 0 <= self.odometry_distance_noise <= 1, "must be in [0, 1] m/m")
        require(self, "novelty_time", 0 < self.novelty_time <= 100_000, "must be in (0, 100000] s")
        rate = self.packet_rate
        require(self, "packet_rate", rate is None or 0 <= rate <= 1e6, "must be None (a packet every step) or >= 0 packets/s")
        for key in ("consume_reward", "progress_reward", "time_penalty"):
            require(self, key, getattr(self, key) >= 0, "must be >= 0")

    def check_relations(self) -> None:
        super().check_relations()
        width, height = self.field_size
        if self.task == "surround":
            require_together(
                self,
                ("robots_per_target", "n_robots", "task"),
                self.robots_per_target <= self.n_robots,
                "surrounding needs robots_per_target <= n_robots",
            )
        require_together(
            self, ("consume_time", "time_limit"), self.consume_time <= self.time_limit, "consume_time must not exceed time_limit"
        )
        require_together(
            self,
            ("cell_size", "field_size"),
            self.cell_size <= min(width, height) / 2,
            "cell_size must be at most half the field",
        )
        require_together(
            self,
            ("packet_rate", "dt"),
            self.packet_rate is None or self.packet_rate * self.dt <= 1 + 1e-9,
            f"packet_rate must be at most one packet per control step (1/dt = {1 / self.dt:g} packets/s)",
        )
        perimeter = 2 * (width + height)
        require_together(
            self,
            ("landmark_spacing", "field_size"),
            self.landmark_spacing <= perimeter,
            f"landmark_spacing must not exceed the field's perimeter ({perimeter:g} m)",
        )
        require_together(
            self, ("reach_radius", "robot_radius"), self.robot_radius <= self.reach_radius, "reach_radius must be >= robot_radius"
        )
        # Room: robots and targets are placed apart; ask for at most a third of the free area.
        margin = self.robot_radius + 0.02
        free = max(0.0, width - 2 * margin) * max(0.0, height - 2 * margin)
        needed = (self.n_robots * (3 * self.robot_radius) ** 2) + self.n_targets * (2 * self.reach_radius) ** 2
        require_together(
            self,
            ("n_robots", "n_targets", "field_size", "robot_radius", "reach_radius"),
            needed <= free / 3,
            "they leave too little room on this field (robots and targets may take a third of it)",
        )

    @property
    def keeps_world_models(self) -> bool:
        """Whether the env keeps a :class:`~teamgym.envs.foraging.world_model.GridWorldModel` per robot (for its observation)."""
        return self.observe_world_model or self.observe_novelty

    @property
    def cycle_limit(self) -> int:
        """Control steps an episode may last: ⌈``time_limit / dt``⌉, capped by ``max_cycles`` (by 10⁶ when it is None)."""
        cap = DERIVED_CYCLES_CAP if self.max_cycles is None else self.max_cycles
        return min(cap, math.ceil(self.time_limit / self.dt - 1e-9))

    @property
    def grid(self) -> GridSpec:
        return GridSpec(float(self.field_size[0]), float(self.field_size[1]), self.cell_size)

    @property
    def robot_spec(self) -> RobotSpec:
        """A Viper-sized differential-drive robot (RoboCup small size: 180 mm across)."""
        r = self.robot_radius
        return RobotSpec(
            radius=r,
            wheel_base=1.6 * r,
            wheel_radius=0.25 * r,
            max_wheel_speed=self.max_speed,
            mass=1.5,
            max_motor_force=20.0,
        )
