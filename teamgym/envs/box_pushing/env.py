"""BoxPushing-v0: Khepera robots push light and heavy boxes to a lamp-lit wall (paper 004).

A 110 cm × 90 cm table enclosed by walls; a lamp beside it (default 15 cm outside the middle
of the right wall); the goal is the wall nearest the lamp (section 2.1). ``n_light_boxes``
boxes that one robot can slide and ``n_heavy_boxes`` that need two or more robots pushing
together: the difference is only mass and ground friction against the motors' force limit
(see :mod:`teamgym.envs.box_pushing.config`). Boxes are clear plastic: the light sensor sees
the lamp through them; by default nothing casts a shadow ("a robot can sense the direction of
the goal (lamp) at any place", section 2.1); ``light_shadows=True`` lets robots do so.
There is no communication; the paper's situations S1–S4 are presets (``situation="S3"``).

Observations (flat float32, the same sensor readings whatever the policy; ``env.decode``):

=============  =====  ============================================================
field          shape  meaning
=============  =====  ============================================================
``proximity``  (8,)   Khepera ring distances (m), ``sensor_range`` if free; rays as
                      in the paper's Fig. 3 (0 left, 1–4 front, 5 right, 6–7 back)
``light``      (8,)   lamp intensity per sensor direction, I₀ max(0, cos)/d², I₀ = 1;
                      the sensor saturates at ``LIGHT_SATURATION`` (1000)
``encoders``   (4,)   last step's commanded left/right and actual left/right wheel
                      rotation (rad); actual ≪ commanded is the paper's "no-rotation";
                      saturates at ``teamgym.envs.bounds.wheel_rotation_limit``
``busy``       (1,)   1 while a multi-cycle primitive runs (its choices are ignored)
``stall``      (1,)   only with ``observe_stall=True``: the robot's consecutive stalled
                      cycles (wheel slip > 0.9) / ``STALL_CAP``, at most 1. A memory the
                      robot keeps from its own encoders, as ``sbs`` does for its
                      "no-rotation" (3 cycles); for memoryless learned policies
=============  =====  ============================================================

``env.object_threshold`` (20 mm, section 3.1) is what the paper's policies call an "object".

Actions (``action_type``): ``"primitives"``, ``Discrete(13)``, the paper's primitive actions
(:class:`teamgym.control.primitives.Primitive`), each selected per 100 ms cycle; or
``"wheels"``, continuous wheel rim speeds for RL.

Reward (shared by the team, every step): ``progress_reward`` × (decrease of the gaps between
boxes and the goal wall, m) − ``time_penalty``, + ``success_bonus`` on success. Success:
``boxes_to_goal`` boxes (0: every box in the world) have touched the goal wall; every live
robot then terminates. Episodes are truncated after ``max_cycles`` steps.

Dynamic environment (section 4.2): :meth:`BoxPushing.add_robot`, :meth:`~BoxPushing.remove_robot`,
:meth:`~BoxPushing.break_down`, :meth:`~BoxPushing.add_box`, :meth:`~BoxPushing.remove_box`
between steps, or ``events`` in the config, applied at the end of the given step. Robots
come from spares in ``possible_agents`` (``n_spare_robots``); an added robot joins ``agents``
in the next step's returns, a removed or broken robot is terminated in them (a broken robot
stays on the table as an obstacle: motors off, wheels locked, it resists three times the
force one robot can push with).

Metrics in ``infos[agent]``: ``success``, ``time_to_goal`` (s, once successful),
``boxes_delivered``, ``box_progress`` (m, the team's), ``path_length``, ``collisions``,
``stalled_steps`` (steps with commanded motion and wheel slip > 0.9), ``broken_down``, ``removed``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.control.primitives import PrimitiveParams
from teamgym.envs.actions import ActionType, WheelSpeedAction
from teamgym.envs.base import EpisodeOverError, TeamEnv
from teamgym.envs.bounds import wheel_rotation_limit
from teamgym.envs.box_pushing.actions import PrimitiveAction
from teamgym.envs.box_pushing.config import SITUATIONS, BoxPushingConfig, BoxPushingV1Config, Event
from teamgym.envs.box_pushing.phases import BoxPushingPhases
from teamgym.envs.box_pushing.scene import GoalWall, Placer
from teamgym.envs.box_pushing.sensing import read_sensors
from teamgym.envs.box_pushing.state import LEAVING, BoxPushingArrays
from teamgym.envs.infos import InfoKey, metrics, unknown
from teamgym.envs.spaces import Field, ObservationLayout
from teamgym.sim.categories import OPAQUE, Category
from teamgym.sim.chipmunk import body_poses
from teamgym.sim.objects import Box, Lamp
from teamgym.sim.render import Overlay
from teamgym.sim.robot import DiffDriveRobot, RobotSpec, body_command, wheel_speeds
from teamgym.sim.sensors import KHEPERA_RING, LightSensor, ProximityRing, SensorSuite, WheelEncoders
from teamgym.sim.world import World

__all__ = ["SITUATIONS", "BoxPushing", "BoxPushingConfig", "BoxPushingV1", "BoxPushingV1Config", "env", "parallel_env"]

_ROBOT_WALL_GAP = 0.005
_ROBOT_CLEARANCE = 0.01
#: Consecutive stalled cycles at which the ``stall`` observation reads 1 (1 s at the default Δt).
STALL_CAP = 10
_BRAKE_FACTOR = 3.0
_NO_POSE = (0.0, 0.0, 0.0)
#: Where the light sensor saturates (light units, I₀ = 1 at 1 m): 2.5 times the brightest
#: noise-free reading, 400 at the sensor's 5 cm minimum distance; reached only with the lamp
#: beside the table and strong gains or noise (the default lamp gives at most about 80).
LIGHT_SATURATION = 1000.0


class BoxPushing(TeamEnv):
    """Cooperative box pushing without communication (paper 004). See the module docstring."""

    metadata = {**TeamEnv.metadata, "name": "box_pushing_v0"}
    rebase_cycles = 400  # replaying 400 control cycles takes about 0.1-0.2 s (TeamEnv: copying and pickling)
    config_class = BoxPushingConfig
    config: BoxPushingConfig
    pixels_per_metre = 400.0
    phases_class = BoxPushingPhases  # the step's phases over BoxPushingArrays rows, one numpy pass for a batch's copies
    stall_cap = STALL_CAP

    def _setup(self) -> None:
        c = self.config
        contact = "centre" if c.table_friction == "joint" else "wheels"
        self.spec_robot = RobotSpec(max_wheel_speed=c.max_wheel_speed, max_motor_force=c.max_motor_force, ground_contact=contact)
        level = c.noise_level
        self.ring = ProximityRing(KHEPERA_RING, c.sensor_range, level("sensor_noise"), level("sensor_noise_relative"))
        blockers = OPAQUE & ~Category.WALL.bit if c.light_shadows else 0
        self.light = LightSensor(
            c.lamp,
            1.0,
            KHEPERA_RING,
            noise_std=level("light_noise"),
            blockers=blockers,
            relative_noise=level("light_noise_relative"),
            gain_spread=level("light_gain_spread"),
            saturation=LIGHT_SATURATION,
        )
        self.encoder_limit = wheel_rotation_limit(c, self.spec_robot)
        encoders = WheelEncoders(level("encoder_noise"), c.effective_encoder_resolution, self.encoder_limit)
        self.sensors = SensorSuite({"proximity": self.ring, "light": self.light, "encoders": encoders})
        self.goal = GoalWall(c.goal_side(), c.table_width, c.table_height)
        self.object_threshold = c.object_threshold
        self.primitive_params = PrimitiveParams(
            dt=c.dt,
            cruise_speed=c.cruise_speed,
            push_speed=c.push_speed,
            follow_speed=c.follow_speed,
            turn_rate=c.turn_rate,
            turn_step=c.turn_step,
            direction_change_jitter=c.direction_change_jitter,
            side_offset=c.side_offset,
            follow_step=c.follow_step,
            contact_distance=c.object_threshold,
            sensor_range=c.sensor_range,
            ray_angles=tuple(KHEPERA_RING.tolist()),
            wheel_radius=self.spec_robot.wheel_radius,
            wheel_base=self.spec_robot.wheel_base,
        )
        self.events: list[Event] = c.parsed_events()
        self.box_capacity = c.n_light_boxes + c.n_heavy_boxes + c.n_spare_boxes
        n = len(self.possible_agents)
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(5 * n + 6 * self.box_capacity,), dtype=np.float32)
        self._use_rows(BoxPushingArrays(c, n, self.box_capacity, self.sensors.width, len(self.events), self.light.width), 0)

    def _check_feasible(self) -> None:
        """Refuse at ``make()`` a config whose initial scene cannot be placed (tried on 32 seeds)."""
        for seed in range(32):
            self._sample_initial(np.random.default_rng(seed))

    # -- TeamEnv hooks ----------------------------------------------------------------------
    def _agent_names(self) -> list[str]:
        return [f"robot_{i}" for i in range(self.config.n_robots + self.config.n_spare_robots)]

    def _make_action_type(self) -> ActionType:
        if self.config.action_type == "wheels":
            return WheelSpeedAction(self.spec_robot)
        return PrimitiveAction(self.primitive_params)

    def _make_layout(self) -> ObservationLayout:
        rays, c = len(KHEPERA_RING), self.config
        fields = [
            Field("proximity", (rays,), 0.0, c.sensor_range),
            Field("light", (rays,), 0.0, LIGHT_SATURATION),
            Field("encoders", (4,), -self.encoder_limit, self.encoder_limit),
            Field("busy", (1,), 0.0, 1.0),
        ]
        if self.config.observe_stall:
            fields.append(Field("stall", (1,), 0.0, 1.0))
        return ObservationLayout(fields)

    def _build(self, rng: np.random.Generator) -> None:
        c = self.config
        self.world = World((c.table_width, c.table_height), **c.world_options())
        self.world.add_boundary()
        self.world.add(Lamp("lamp", c.lamp))
        self.robots = {}
        primitives = self._primitives
        if primitives is not None:
            primitives.begin(self.possible_agents)
        self.boxes: list[Box | None] = [None] * self.box_capacity
        self._arrays.start(self._copy, self.sensors.slices["proximity"])
        boxes, robots = self._sample_initial(rng)
        for heavy, (x, y, angle) in boxes:
            self._place_box(heavy, x, y, angle)
        for x, y, heading in robots:
            self._place_robot(x, y, heading)
        self.live_agents = [a for a in self.possible_agents if a in self.robots]
        self._joining = []
        self.world.read_states()
        self._read_sensors(self.live_agents)

    # -- per-episode state (this copy's rows of ``self._arrays``) -------------------------
    def _use_rows(self, team: BoxPushingArrays, k: int) -> None:
        """Keep this env's episode state in copy row ``k`` of ``team`` (a batch's; see :class:`BoxPushingArrays`)."""
        self._arrays, self._copy = team, k

    def _episode_state(self) -> dict[str, Any]:
        """The base's, with this copy's rows of ``_arrays`` in place of the arrays (a batch's hold every copy)."""
        state = super()._episode_state()
        team, k = state.pop("_arrays"), state.pop("_copy")
        state["_box_rows"] = team.row(k)
        return state

    def _adopt_episode_state(self, state: dict[str, Any]) -> None:
        rows = state.pop("_box_rows", None)
        if rows is None:  # a snapshot of a release that kept the episode in attributes
            rows = _rows_of_attributes(self, state)
        super()._adopt_episode_state(state)
        self._arrays.set_row(self._copy, rows)

    @property
    def _primitives(self) -> PrimitiveAction | None:
        """The primitive action type (inside a learned message's wrapper), or ``None`` with wheel speeds."""
        action_type = getattr(self.action_type, "motion", self.action_type)
        return action_type if isinstance(action_type, PrimitiveAction) else None

    @property
    def executors(self) -> dict:
        """Each robot's primitive executor (owned by the action type; empty with wheel speeds)."""
        primitives = self._primitives
        return {} if primitives is None else primitives.executors

    @property
    def skipped_events(self) -> list[Event]:
        """Scheduled events of this episode that could not be applied (robot already gone, table full)."""
        return [event for event, skipped in zip(self.events, self._arrays.event_skipped[self._copy].tolist()) if skipped]

    def _before_physics(self) -> None:
        """Motor noise: each wheel's commanded speed is scaled by 1 + N(0, σ²), σ = ``noise`` × ``motor_noise``."""
        noise = self.config.noise_level("motor_noise")
        if noise <= 0:
            return
        base = self.spec_robot.wheel_base
        draws = self.np_random.normal(1.0, noise, size=(len(self.live_agents), 2))
        for agent, (a, b) in zip(self.live_agents, draws.tolist()):  # scale_wheel_speeds robot by robot (cheaper for a few)
            robot = self.robots[agent]
            left, right = wheel_speeds(*robot.command, base)
            robot.set_command(*body_command(left * a, right * b, base))

    def _update_state(self) -> None:
        """Contacts, and the boxes' gaps to the goal wall (this step's progress)."""
        self._count_contacts()
        team, k = self._arrays, self._copy
        team.update_boxes(slice(k, k + 1), self.goal, self._box_poses()[None])

    def _apply_events(self) -> None:
        """Scheduled events (``events`` in the config) due at this control step."""
        events, team, k = self.events, self._arrays, self._copy
        while team.next_event[k] < len(events) and events[team.next_event[k]].cycle <= self.cycles:
            self._apply_event(int(team.next_event[k]))
            team.next_event[k] += 1

    def _check_goals(self) -> None:
        k = self._copy
        self._arrays.check_goals(slice(k, k + 1), np.array([self.cycles]))

    def _accumulate_rewards(self, total: np.ndarray) -> None:
        """The team's shared reward: progress of the boxes, time penalty, success bonus."""
        k = self._copy
        total[self._live_rows()] += float(self._arrays.rewards(slice(k, k + 1))[0])

    def _sense(self) -> None:
        """Sensors of the robots that go on, including robots added by events in this step."""
        self._read_sensors(self._going_on())

    def _going_on(self) -> list[str]:
        """The robots that stay in the episode after this control step (none once the team succeeded)."""
        team, k = self._arrays, self._copy
        if team.success[k]:
            return []
        leaving, row = team.leaving[k], self._row
        return [a for a in [*self.live_agents, *self._joining] if not leaving[row[a]]]

    def _terminations(self) -> dict[str, bool]:
        """Every robot on success; removed and broken robots (their status is recorded)."""
        team, k = self._arrays, self._copy
        success, leaving = bool(team.success[k]), team.leaving[k]
        if not leaving.any():
            return dict.fromkeys(self.live_agents, success)
        going = leaving.tolist()
        terminations = {a: success or bool(going[self._row[a]]) for a in self.live_agents}
        primitives = self._primitives
        if primitives is not None:
            for i in np.flatnonzero(leaving).tolist():
                primitives.cancel(self.possible_agents[i])
        team.status[k] = np.where(leaving != 0, leaving, team.status[k])
        leaving[:] = 0
        return terminations

    def _observe(self, out: np.ndarray) -> None:
        if not self.live_agents:
            return
        ks, busy = slice(self._copy, self._copy + 1), self._busy_rows()[None]
        if len(self.live_agents) == len(self.possible_agents):  # everyone live: rows in order, straight into ``out``
            self._arrays.observe(ks, self.layout, busy, self.stall_cap, out[None])
            return
        every = np.empty((1, len(self.possible_agents), out.shape[1]), dtype=out.dtype)
        self._arrays.observe(ks, self.layout, busy, self.stall_cap, every)
        out[:] = every[0, self._live_rows()]

    def _busy_rows(self) -> np.ndarray:
        """``(N,)``: 1 for robots whose primitive executor runs a multi-cycle program."""
        busy = np.zeros(len(self.possible_agents))
        primitives = self._primitives
        if primitives is not None:
            rows = self._live_rows()
            busy[rows] = primitives.busy(self.live_agents)
        return busy

    def _info_keys(self) -> dict[str, InfoKey]:
        """Counts from reset on; ``time_to_goal`` (s) NaN until the team succeeds."""
        keys = ("boxes_delivered", "box_progress", "path_length", "collisions", "stalled_steps", "broken_down", "removed")
        return {**metrics(*keys), **unknown("time_to_goal")}

    def _metrics(self, agent: str) -> dict[str, Any]:
        return self._metrics_of([agent])[agent]

    def _metrics_of(self, agents: list[str]) -> dict[str, dict[str, Any]]:
        """Every agent's metrics from this copy's rows (team values read once)."""
        team, k, row = self._arrays, self._copy, self._row
        success = bool(team.success[k])
        team_metrics = {
            "success": success,
            "boxes_delivered": int(team.box_delivered[k].sum()),
            "box_progress": float(team.progress[k]),
        }
        collisions, stalled, status = team.collisions[k].tolist(), team.stalled[k].tolist(), team.status[k].tolist()
        removed, broken = LEAVING["removed"], LEAVING["broken_down"]
        out = {}
        for agent in agents:
            i, robot = row[agent], self.robots.get(agent)
            metrics = {
                **team_metrics,
                "path_length": float(robot.odometer) if robot is not None else 0.0,
                "collisions": collisions[i],
                "stalled_steps": stalled[i],
                "broken_down": status[i] == broken,
                "removed": status[i] == removed,
            }
            if success:
                metrics["time_to_goal"] = float(team.success_time[k])
            out[agent] = metrics
        return out

    def episode_success(self) -> bool:
        """Whether the episode reached its goal (``boxes_to_goal`` boxes at the goal wall)."""
        return bool(self._arrays.success[self._copy]) if self.world is not None else False

    def light_gains(self, agent: str) -> np.ndarray:
        """``agent``'s light sensors' gains this episode (``light_gain_spread``; ones without), a copy."""
        return self._arrays.light_gains[self._copy, self._row[agent]].copy()

    def is_delivered(self, name: str) -> bool:
        """Whether box ``name`` has touched the goal wall in this episode."""
        return bool(self._arrays.box_delivered[self._copy, self._box_slot(name)])

    # -- dynamic environment (paper 004, section 4.2) ---------------------------------------
    def add_robot(self, position: tuple[float, float] | None = None, heading: float | None = None) -> str:
        """Put a spare robot on the table now (random free spot and heading if not given).

        Returns its agent name; it joins ``agents`` in the returns of the next ``step``.
        Raises ``ValueError`` if no spare is left or the spot is not free.
        """
        self._require_running("add_robot")
        self._check_spare()
        x, y, theta = self._draw(self._robot_spot, position, heading)
        self._record("add_robot", position, heading)
        return self._place_robot(x, y, theta)

    def remove_robot(self, agent: str) -> None:
        """Take ``agent``'s robot off the table now; the agent terminates in the next step's returns."""
        self._check_live(agent, "remove_robot")
        self._record("remove_robot", agent)
        self._remove_robot(agent)

    def break_down(self, agent: str) -> None:
        """``agent``'s robot breaks down now: it stops for good and stays as an obstacle; it terminates in the next step."""
        self._check_live(agent, "break_down")
        self._record("break_down", agent)
        self._break_down(agent)

    def add_box(self, heavy: bool = False, position: tuple[float, float] | None = None, angle: float | None = None) -> str:
        """Put a light or heavy box on the table now (random free spot and angle if not given); returns its name."""
        self._require_running("add_box")
        if not isinstance(heavy, (bool, np.bool_)):
            raise TypeError(f"add_box: heavy must be a bool, got {heavy!r}")
        if self._arrays.n_boxes[self._copy] >= self.box_capacity:
            raise ValueError(f"add_box: all {self.box_capacity} box slots are used; raise n_spare_boxes")
        x, y, theta = self._draw(self._box_spot, bool(heavy), position, angle)
        self._record("add_box", bool(heavy), position, angle)
        return self._place_box(bool(heavy), x, y, theta)

    def remove_box(self, name: str) -> None:
        """Take box ``name`` off the table now."""
        self._require_running("remove_box")
        slot = self._box_slot(name)
        self._record("remove_box", name)
        self._remove_box(slot)

    def box_names(self) -> list[str]:
        """Names of the boxes on the table."""
        return [b.name for b in self.boxes if b is not None]

    def is_heavy(self, name: str) -> bool:
        return bool(self._arrays.box_heavy[self._copy, self._box_slot(name)])

    def _draw(self, spot, *args) -> tuple[float, float, float]:
        """``spot(*args)``; if it fails, the env's random stream is left as it was (the failed call is not logged)."""
        state = self.np_random.bit_generator.state
        try:
            return spot(*args)
        except (TypeError, ValueError):
            self.np_random.bit_generator.state = state
            raise

    # -- events -----------------------------------------------------------------------------
    def _apply_event(self, index: int) -> None:
        """Scheduled event ``index``; impossible ones (robot gone, table full) are skipped and flagged."""
        event = self.events[index]
        try:
            if event.kind == "add_robot":
                self._check_spare()
                x, y, theta = self._robot_spot(event.args[:2] or None, event.args[2] if len(event.args) > 2 else None)
                self._place_robot(x, y, theta)
            elif event.kind in ("remove_robot", "break_down"):
                self._check_live(event.args[0], event.kind)
                (self._remove_robot if event.kind == "remove_robot" else self._break_down)(event.args[0])
            elif event.kind == "remove_box":
                self._remove_box(self._box_slot(event.args[0]))
            else:
                heavy = event.kind == "add_heavy_box"
                x, y, theta = self._box_spot(heavy, event.args[:2] or None, event.args[2] if len(event.args) > 2 else None)
                self._place_box(heavy, x, y, theta)
        except (ValueError, KeyError):
            self._arrays.event_skipped[self._copy, index] = True

    def _place_robot(self, x: float, y: float, heading: float) -> str:
        team, k = self._arrays, self._copy
        name = self.possible_agents[team.robots_used[k]]
        team.robots_used[k] += 1
        self.robots[name] = self.world.add(DiffDriveRobot(name, (x, y), heading, self.spec_robot))
        gains = self.light.draw_gains(self.np_random)  # this robot's light sensors' sensitivities
        if gains is not None:
            team.light_gains[k, self._row[name]] = gains
        self.world.read_states()  # the state rows follow the robots on the table
        self._admit(name)
        return name

    def _remove_robot(self, agent: str) -> None:
        self.world.remove(agent)
        self._leave(agent, "removed")
        self.world.read_states()

    def _break_down(self, agent: str) -> None:
        robot = self.robots[agent]
        robot.disable()
        # Motors off, wheels locked by the gearbox (a Khepera's is not back-drivable): the
        # robot resists pushing harder than any one robot can push.
        robot.brake(_BRAKE_FACTOR)
        self._leave(agent, "broken_down")

    def _leave(self, agent: str, why: str) -> None:
        """``agent`` leaves at the end of this step (``why``: a key of :data:`LEAVING`); its program is abandoned."""
        primitives = self._primitives
        if primitives is not None:
            primitives.cancel(agent)
        self._arrays.leaving[self._copy, self._row[agent]] = LEAVING[why]

    def _place_box(self, heavy: bool, x: float, y: float, angle: float) -> str:
        c, team, k = self.config, self._arrays, self._copy
        slot = int(team.n_boxes[k])
        team.n_boxes[k] += 1
        size, mass = (c.heavy_box_size, c.heavy_box_mass) if heavy else (c.light_box_size, c.light_box_mass)
        box = Box(f"box_{slot}", (size, size), (x, y), mass, c.box_friction, angle, c.table_friction, c.support_points)
        self.world.add(box)
        self.boxes[slot] = box
        team.box_present[k, slot], team.box_heavy[k, slot], team.box_half[k, slot] = True, heavy, size / 2
        gap = float(self.goal.gaps(np.array([[x, y, angle]]), team.box_half[k, slot : slot + 1])[0])
        team.box_gap[k, slot] = gap
        team.box_delivered[k, slot] = gap <= c.goal_tolerance
        return box.name

    def _remove_box(self, slot: int) -> None:
        self.world.remove(self.boxes[slot].name)
        self.boxes[slot] = None
        self._arrays.box_present[self._copy, slot] = False

    # -- checks and spots -------------------------------------------------------------------
    def _require_running(self, what: str) -> None:
        if self.world is None or not self.live_agents:
            raise EpisodeOverError(f"{what}() needs a running episode; call reset() first")

    def _check_spare(self) -> None:
        if self._arrays.robots_used[self._copy] >= len(self.possible_agents):
            raise ValueError(
                f"add_robot: no spare robot left; all {len(self.possible_agents)} possible agents are used (n_spare_robots)"
            )

    def _check_live(self, agent: str, what: str) -> None:
        self._require_running(what)
        if agent not in self.possible_agents:
            raise KeyError(f"{what}: unknown agent {agent!r}; possible agents are {self.possible_agents}")
        if agent not in self.live_agents or self._arrays.leaving[self._copy, self._row[agent]]:
            raise ValueError(f"{what}: {agent!r} is not a live agent; live agents are {self.live_agents}")

    def _box_slot(self, name: str) -> int:
        for slot, box in enumerate(self.boxes):
            if box is not None and box.name == name:
                return slot
        raise KeyError(f"no box named {name!r} on the table; boxes are {self.box_names()}")

    def _occupied(self) -> list[tuple[float, float, float]]:
        spots = [(*r.position, r.spec.radius) for r in self.world.robots]
        spots += [(*b.position, b.bounding_radius) for b in self.boxes if b is not None]
        return spots

    def _robot_spot(self, position, heading) -> tuple[float, float, float]:
        r = self.spec_robot.radius
        theta = float(self.np_random.uniform(-np.pi, np.pi)) if heading is None else _finite(heading, "heading")
        placer = Placer(self.config.table_width, self.config.table_height, self.np_random, type(self.config).__name__)
        if position is None:
            x, y = placer.sample(r, _ROBOT_WALL_GAP, self._occupied(), _ROBOT_CLEARANCE, "robot")
            return x, y, theta
        x, y = self._spot(position, r, "robot")
        if not placer.is_free(x, y, r, self._occupied(), 0.002):
            raise ValueError(f"add_robot: position {(x, y)} is not free")
        return x, y, theta

    def _box_spot(self, heavy: bool, position, angle) -> tuple[float, float, float]:
        c = self.config
        half = (c.heavy_box_size if heavy else c.light_box_size) / 2
        if angle is not None:
            theta = _finite(angle, "angle")
        else:
            theta = float(self.np_random.uniform(0, np.pi / 2)) if self.config.box_orientation == "random" else 0.0
        placer = Placer(c.table_width, c.table_height, self.np_random, type(c).__name__)
        radius = half * math.sqrt(2)
        if position is None:
            x, y = placer.sample(radius, c.box_margin, self._occupied(), 2 * self.spec_robot.radius, "box")
            return x, y, theta
        x, y = self._spot(position, half * (abs(math.cos(theta)) + abs(math.sin(theta))), "box")
        if not placer.is_free(x, y, radius, self._occupied(), 0.002):
            raise ValueError(f"add_box: position {(x, y)} is not free")
        return x, y, theta

    def _spot(self, position, extent: float, what: str) -> tuple[float, float]:
        try:
            x, y = (_finite(v, "position") for v in position)
        except (TypeError, ValueError):
            raise ValueError(f"add_{what}: position must be two finite numbers (m), got {position!r}") from None
        c = self.config
        if not (extent <= x <= c.table_width - extent and extent <= y <= c.table_height - extent):
            raise ValueError(f"add_{what}: position {(x, y)} puts the {what} off the table")
        return x, y

    def _sample_initial(self, rng: np.random.Generator) -> tuple[list, list]:
        """Initial boxes (not touching walls, section 4) and robots, as ``(heavy, (x, y, angle))`` and ``(x, y, θ)``."""
        c = self.config
        placer = Placer(c.table_width, c.table_height, rng, type(c).__name__)
        occupied: list[tuple[float, float, float]] = []
        boxes = []
        for heavy in [False] * c.n_light_boxes + [True] * c.n_heavy_boxes:
            half = (c.heavy_box_size if heavy else c.light_box_size) / 2
            x, y = placer.sample(half * math.sqrt(2), c.box_margin, occupied, 2 * self.spec_robot.radius, "box")
            occupied.append((x, y, half * math.sqrt(2)))
            angle = float(rng.uniform(0, np.pi / 2)) if c.box_orientation == "random" else 0.0
            boxes.append((heavy, (x, y, angle)))
        robots = []
        for _ in range(c.n_robots):
            x, y = placer.sample(self.spec_robot.radius, _ROBOT_WALL_GAP, occupied, _ROBOT_CLEARANCE, "robot")
            occupied.append((x, y, self.spec_robot.radius))
            robots.append((x, y, float(rng.uniform(-np.pi, np.pi))))
        return boxes, robots

    # -- per-step state ---------------------------------------------------------------------
    def _read_sensors(self, agents: list[str]) -> None:
        """Proximity, light and encoder readings of ``agents`` (one sensor suite); executors see them too."""
        read_sensors([(self, agents)])

    def _count_contacts(self) -> None:
        if self.world.contacts:  # contacts that began in this control step (none: every count is 0)
            self._arrays.collisions[self._copy] += self.world.contacts_per(self.possible_agents)

    def _update_boxes(self) -> float:
        """Measure the boxes' gaps and deliveries anew (boxes moved by hand); returns the gaps' decrease (m), not counted."""
        team, k = self._arrays, self._copy
        team.update_boxes(slice(k, k + 1), self.goal, self._box_poses()[None], accumulate=False)
        return float(team.step_progress[k])

    def _box_poses(self) -> np.ndarray:
        """``(B, 3)``: ``(x, y, angle)`` of every box slot (zeros for empty slots)."""
        return np.array(self._box_pose_rows()).reshape(-1, 3)

    def _box_pose_rows(self) -> list[tuple[float, float, float]]:
        """:meth:`_box_poses` as a list of tuples (a batch makes one array of every copy's)."""
        present = body_poses([box.body for box in self.boxes if box is not None])
        if len(present) == len(self.boxes):
            return present
        poses = iter(present)
        return [next(poses) if box is not None else _NO_POSE for box in self.boxes]

    # -- state and rendering ----------------------------------------------------------------
    def state(self) -> np.ndarray:
        """Global state: per possible robot (x, y, θ, present, working), per box slot (x, y, angle, heavy, present, delivered)."""
        if self.world is None:
            raise RuntimeError("state() called before reset()")
        robots = np.zeros((len(self.possible_agents), 5))
        for agent, robot in self.robots.items():
            if robot.space is not None:
                robots[self._row[agent]] = (*robot.pose, 1.0, float(robot.enabled))
        boxes = np.zeros((self.box_capacity, 6))
        heavy, delivered = self._arrays.box_heavy[self._copy], self._arrays.box_delivered[self._copy]
        for k, box in enumerate(self.boxes):
            if box is not None:
                boxes[k] = (*box.position, box.body.angle, float(heavy[k]), 1.0, float(delivered[k]))
        return np.concatenate([robots.ravel(), boxes.ravel()]).astype(np.float32)

    def _overlay(self) -> Overlay:
        overlay = Overlay()
        overlay.paths.append((list(self.goal.segment(self.config.table_width, self.config.table_height)), (40, 170, 40)))
        for k, box in enumerate(self.boxes):
            if box is not None and self._arrays.box_heavy[self._copy, k]:
                corners = [box.body.local_to_world(v) for v in box.local_vertices]
                overlay.paths.append(([tuple(corners[0]), tuple(corners[2])], (90, 50, 20)))
                overlay.paths.append(([tuple(corners[1]), tuple(corners[3])], (90, 50, 20)))
        return overlay


class BoxPushingV1(BoxPushing):
    """``BoxPushing-v1``: :class:`BoxPushing` with :class:`BoxPushingV1Config`'s defaults.

    Version history (``docs/box_pushing.md``):

    * **v0**: ground friction of a box is one force limit and one independent torque limit
      (a pushed box slides or turns, never both in proportion); robots hold to the ground
      at their centre; sensors, encoders and motors are exact by default.
    * **v1**: planar Coulomb friction at support points (boxes on their four corners,
      robots on their two wheels), so an off-centre push turns a sliding box; Khepera-like
      noise on proximity, light, encoders and wheel speeds (``noise=0``: none). The same
      keys as v0; only defaults differ, so ``make("BoxPushing-v1", table_friction="joint",
      noise=0)`` is v0.
    """

    metadata = {**BoxPushing.metadata, "name": "box_pushing_v1"}
    config_class = BoxPushingV1Config
    config: BoxPushingV1Config


def _rows_of_attributes(env: BoxPushing, state: dict[str, Any]) -> dict[str, np.ndarray]:
    """The episode rows of a snapshot that earlier releases wrote (the state in ``_*`` attributes); ``state`` loses them.

    Their executors move to the action type, as this release keeps them.
    """
    old = {key: state.pop(key) for key in [*state] if key.startswith("_") and key not in env.__dict__}
    old.update((key, state.pop(key)) for key in ("executors", "skipped_events") if key in state)
    action_type = getattr(state.get("action_type"), "motion", state.get("action_type"))
    if isinstance(action_type, PrimitiveAction):
        action_type.params, action_type.executors = env.primitive_params, old["executors"]
    rows = env._arrays.row(env._copy)
    rows["readings"][:] = old["_readings"]
    light = state.get("light")
    for agent, gains in (getattr(light, "_gains", None) or {}).items():
        rows["light_gains"][env._row[agent]] = gains
    if light is not None:
        light.forget_calibrations()
    for name in ("collisions", "stalled", "stall_run"):
        rows[name][:] = old[f"_{name}"]
    for agent, status in old["_status"].items():
        rows["status"][env._row[agent]] = LEAVING.get(status, 0)
    for agent, why in old["_leaving"].items():
        rows["leaving"][env._row[agent]] = LEAVING[why]
    rows["box_present"][:] = [box is not None for box in state["boxes"]]
    for name, key in (("box_heavy", "_heavy"), ("box_half", "_half"), ("box_gap", "_gap"), ("box_delivered", "_delivered")):
        rows[name][:] = old[key]
    rows.update(n_boxes=old["_n_boxes"], robots_used=old["_n_robots_used"], next_event=old["_next_event"])
    rows.update(progress=old["_progress"], step_progress=old.get("_step_progress", 0.0), success_time=old["_success_time"])
    rows.update(success=old["_success"], new_success=old.get("_newly_successful", False))
    skipped = old.get("skipped_events", [])
    rows["event_skipped"][:] = [any(event is s or event == s for s in skipped) for event in env.events]
    return rows


def _finite(value: Any, what: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{what} must be a finite number, got {value!r}")
    if not math.isfinite(float(value)):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return float(value)


def parallel_env(render_mode: str | None = None, **config: Any) -> BoxPushing:
    """The PettingZoo parallel env (same as ``teamgym.make("BoxPushing-v0", ...)``)."""
    return BoxPushing(render_mode=render_mode, **config)


def env(render_mode: str | None = None, **config: Any):
    """The AEC form of the env, through PettingZoo's ``parallel_to_aec``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(render_mode=render_mode, **config))
