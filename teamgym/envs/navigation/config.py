"""Configuration of ``Navigation-v0`` (paper 001)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Literal

from teamgym.envs.bounds import PROXIMITY_LIMITS, Limit, require_limits, require_ring_noise
from teamgym.envs.config import EnvConfig, require, require_together


@dataclass(frozen=True)
class NavigationConfig(EnvConfig):
    """Configuration of ``Navigation-v0`` (SI units; angles of the heading set in deg/s).

    ``local_features`` appends the goal, team mates and obstacles in the robot's own frame
    (fields ``goal_local``, ``mates_local``, ``obstacles_local``) after the paper's fields,
    which stay as they are; for learned policies (an MLP need not learn the rotation).
    ``mate_goals`` appends field ``mate_goals`` (N−1, 2): each team mate's goal relative to
    the robot (in its own frame with ``local_features``, else world axes), the information
    that paper 001's central arbiter has and a robot's own observation lacks.
    ``virtual_forces`` appends field ``forces`` (5, 3): paper 001's virtual forces at the
    robot's current pose (eqs. 15, 19, 21 with the default gains of
    :class:`~teamgym.control.forces.ForceGains`): attraction to its goal, repulsion from its
    team mates, from the obstacles (their centres one step ahead by their velocity, eq. 23),
    from the points its proximity rays hit, and their sum; each as the unit direction in the
    robot's frame (x ahead, y left; zero for no force) and log(1 + |F|). For learned policies
    that imitate ``nash``, whose losses (eq. 25) are these forces at predicted poses.

    ``actuation_delay`` T0 is at most ``MAX_DELAY_STEPS`` · ``dt``; above ``dt`` a command acts in a
    later control step (a command queue, see :meth:`Navigation._delay_actuation`). ``true_delay``:
    ``"random"`` draws each robot's true delay ½ T0 (1 + δt) every step (section 6.1);
    ``"fixed"`` makes it T0 in every step (to study one true delay, e.g. in (0.9Δt, Δt]).

    ``READING_LIMITS`` (the proximity ring): ``sensor_range`` and ``sensor_noise`` in [0, 10] m,
    and ``sensor_noise`` at most ``sensor_range`` (a larger std saturates every ray).
    """

    #: Own ranges of the keys that scale a sensor reading (see the class docstring).
    READING_LIMITS: ClassVar[dict[str, Limit]] = PROXIMITY_LIMITS

    #: Largest ``actuation_delay`` in control steps (the delay study of issue 26 runs T0 up to 8Δt).
    MAX_DELAY_STEPS: ClassVar[int] = 8

    body_speed_keys: ClassVar[tuple[str, ...]] = ("max_wheel_speed", "obstacle_speed")
    default_body_speed: ClassVar[float] = 0.0

    n_robots: int = 3
    n_obstacles: int = 2
    arena_size: float = 2.0
    layout: Literal["random", "circle"] = "random"
    robot_radius: float = 0.0275
    max_wheel_speed: float = 0.4
    max_motor_force: float = 0.6
    obstacle_speed: float = 0.2
    obstacle_radius: float = 0.08
    action_type: Literal["velocity", "wheels", "heading"] = "velocity"
    heading_levels: int = 5
    heading_max_rate: float = 225.0
    v_opt: float = 0.25
    alpha: float = 100.0
    beta: float = 40.0
    target_threshold: float = 0.05
    object_threshold: float = 0.15
    speed_rule: Literal["ahead", "any"] = "ahead"
    walls: bool = True
    obstacle_motion: Literal["bounce", "straight"] = "bounce"
    actuation_delay: float = 0.0
    true_delay: Literal["random", "fixed"] = "random"
    goal_tolerance: float = 0.03
    min_goal_distance: float = 0.6
    spawn_margin: float = 0.05
    sensor_range: float = 0.1
    sensor_noise: float = 0.0
    progress_reward: float = 10.0
    collision_penalty: float = 1.0
    arrival_bonus: float = 10.0
    time_penalty: float = 0.01
    local_features: bool = False
    mate_goals: bool = False
    virtual_forces: bool = False

    def check(self) -> None:
        super().check()
        require(self, "n_robots", 1 <= self.n_robots <= 64, "must be in [1, 64]")
        require(self, "n_obstacles", 0 <= self.n_obstacles <= 32, "must be in [0, 32]")
        require(self, "arena_size", 0.5 <= self.arena_size <= 100, "must be in [0.5, 100] m")
        require(self, "robot_radius", 0.005 <= self.robot_radius <= 0.5, "must be in [0.005, 0.5] m")
        require(self, "max_wheel_speed", 0 < self.max_wheel_speed <= 10, "must be in (0, 10] m/s")
        require(self, "max_motor_force", 0 < self.max_motor_force <= 1000, "must be in (0, 1000] N")
        require(self, "obstacle_speed", 0 <= self.obstacle_speed <= 10, "must be in [0, 10] m/s")
        require(self, "obstacle_radius", 0.01 <= self.obstacle_radius <= 25, "must be in [0.01, 25] m")
        require(self, "heading_levels", 2 <= self.heading_levels <= 64, "must be in [2, 64]")
        require(self, "heading_max_rate", self.heading_max_rate > 0, "must be > 0")
        require(self, "v_opt", 0 < self.v_opt <= 10, "must be in (0, 10] m/s")
        require(self, "actuation_delay", 0 <= self.actuation_delay <= 10, "must be in [0, 10] s")
        require(self, "goal_tolerance", self.goal_tolerance > 0, "must be > 0")
        require(self, "min_goal_distance", self.min_goal_distance >= 0, "must be >= 0 m")
        require(self, "spawn_margin", self.spawn_margin >= 0, "must be >= 0 m")
        require(self, "sensor_range", self.sensor_range > 0, "must be > 0")
        require(self, "sensor_noise", self.sensor_noise >= 0, "must be >= 0")
        require_limits(self, self.READING_LIMITS)

    def check_relations(self) -> None:
        super().check_relations()
        require_ring_noise(self, self.sensor_noise)
        s = self.arena_size
        require_together(
            self, ("obstacle_radius", "arena_size"), self.obstacle_radius <= s / 4, "obstacle_radius must be at most arena_size/4"
        )
        require_together(
            self, ("v_opt", "max_wheel_speed"), self.v_opt <= self.max_wheel_speed, "v_opt must not exceed max_wheel_speed"
        )
        require_together(
            self,
            ("actuation_delay", "dt"),
            self.actuation_delay <= self.MAX_DELAY_STEPS * self.dt,
            f"actuation_delay must be in [0, {self.MAX_DELAY_STEPS}·dt]",
        )
        require_together(
            self,
            ("min_goal_distance", "arena_size"),
            self.min_goal_distance <= 0.8 * s,
            "min_goal_distance must be at most 0.8·arena_size",
        )
        require_together(
            self, ("spawn_margin", "arena_size"), self.spawn_margin < 0.4 * s, "spawn_margin must be below 0.4·arena_size"
        )
        require_together(
            self,
            ("obstacle_motion", "walls"),
            self.obstacle_motion == "bounce" or not self.walls,
            "obstacle_motion='straight' needs walls=False: an obstacle moving straight on would be stopped by the arena walls",
        )
        free = (s - 2 * self.robot_radius) ** 2
        needed = self.n_robots * (4 * self.robot_radius) ** 2 * 2
        require_together(
            self, ("n_robots", "robot_radius", "arena_size"), needed < 0.5 * free, "they leave too little room for the robots"
        )
