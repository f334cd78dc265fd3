"""Paper 001's navigation controller: a non-cooperative game per step with a fair arbiter.

Every control step the robots still driving play one normal-form game: robot i chooses
among the K angular velocities of the env's ``heading`` action type (eq. 11), its loss is
eq. (25) built from virtual forces (:mod:`baselines.navigation.game`), and the arbiter of
section 5.1 picks the team's decision: the pure Nash equilibria (eq. 27) if there are
any, else the min–max strategies (eq. 28); several candidates are resolved by the fair
cost C of eqs. (30)–(31).

Centralisation: the arbiter is the paper's one central module (Fig. 3), so this policy
solves one game per step for the whole team. It acts only on what the robots observe in
``Navigation-v0``: each robot's own pose, previous command and goal from its own
observation, team mates and obstacles as every observation carries them (the paper's
"partially centralised sensory system").
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np

from baselines.game import arbitrate
from baselines.navigation.game import ForceGains, TeamState, loss_tensor
from baselines.policy import Policy
from teamgym.control.heading import AHEAD_COS
from teamgym.envs.navigation.actions import HeadingAction

#: The sensed points of a robot whose rays see nothing (read only).
_NO_POINTS = np.zeros((0, 2))
_NO_POINTS.flags.writeable = False


class NashNavigation(Policy):
    """Game-theoretic navigation of paper 001 (see the module docstring).

    Parameters
    ----------
    gains:
        Force gains and influence distance L0 (eqs. 15, 19, 21).
    model_delay:
        Model the actuation delay T0 in the predictions (eq. 17). With False, T0 = 0 is
        assumed whatever the env's delay (the "T0 not modelled" case of Fig. 5a).
    delay:
        The modelled T0 in seconds, in [0, Δt]; defaults to the env's ``actuation_delay``
        (the worst-case delay the system designer knows). At T0 = Δt eqs. (17) and (26)
        give the same predicted pose for every decision (the decision acts for Δt − T0 = 0):
        every loss ties and the robots cannot steer. Above Δt the decision's factor Δt − T0
        turns negative; that is refused.
    selection:
        ``"arbiter"`` (eqs. 30–31) or ``"first"`` (first equilibrium found: the
        no-arbiter ablation).
    """

    name = "nash"
    env_ids = ("Navigation-v0",)
    observation_fields = ("pose", "last_command", "radius", "goal_offset", "mates", "obstacles", "proximity")
    #: Env config this policy needs; the evaluation CLI applies it unless overridden.
    required_config = {"action_type": "heading"}

    def __init__(
        self,
        env,
        gains: ForceGains | None = None,
        model_delay: bool = True,
        delay: float | None = None,
        selection: str = "arbiter",
    ) -> None:
        super().__init__(env)
        if not isinstance(env.action_type, HeadingAction):
            raise ValueError(
                f"NashNavigation needs the env's 'heading' action type (paper 001, eq. 11), got "
                f"{env.action_type.name!r}; make the env with action_type='heading'"
            )
        if selection not in ("arbiter", "first"):
            raise ValueError(f"selection must be 'arbiter' or 'first', got {selection!r}")
        self.gains = gains or ForceGains()
        self.rates = np.asarray(env.action_type.rates, dtype=float)
        self.heuristic = env.action_type.heuristic
        self.dt = float(env.config.dt)
        self.delay = 0.0 if not model_delay else float(env.config.actuation_delay if delay is None else delay)
        if not 0.0 <= self.delay <= self.dt:
            raise ValueError(
                f"NashNavigation: the modelled delay T0={self.delay!r} s must be in [0, dt={self.dt!r}] (eq. 26 uses Δt − T0); "
                "pass model_delay=False or a smaller delay"
            )
        self.selection = selection
        self.n_robots = env.config.n_robots
        self._order = {agent: i for i, agent in enumerate(env.possible_agents)}
        self._others = [np.array([j for j in range(self.n_robots) if j != i], dtype=np.intp) for i in range(self.n_robots)]
        self._ray_angles = np.asarray(env.ring.angles, dtype=float)
        #: Rays that count for ``speed_rule="ahead"`` (as in :func:`teamgym.control.heading.nearest_gap`).
        self._rays_ahead = np.cos(self._ray_angles) > AHEAD_COS - 1e-9
        self._sensor_range = float(env.config.sensor_range)
        self._speed_rule = env.config.speed_rule
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self._previous_obstacles: np.ndarray | None = None
        self.predicted_obstacles: np.ndarray | None = None
        #: How often each arbiter branch was taken ("nash-unique", "nash-arbiter", ...).
        self.branch_counts: Counter[str] = Counter()
        #: Wall-clock seconds spent per decision (building and solving the game).
        self.decision_times: list[float] = []

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict[str, Any]] | None = None) -> dict[str, int]:
        if not observations:
            return {}
        started = time.perf_counter()
        order = self._order
        agents = sorted(observations, key=order.__getitem__)
        playing = [order[a] for a in agents]
        fields = self._team_fields(observations, agents)
        pose, mates, obstacles = fields["pose"], fields["mates"], fields["obstacles"]
        anchor = pose[0, :2].astype(float)
        obstacles_now = anchor + obstacles[0, :, :2] if obstacles.shape[1] else np.zeros((0, 2))
        radii = obstacles[0, :, 4] if obstacles.shape[1] else np.zeros(0)
        if self._previous_obstacles is not None and len(self._previous_obstacles) == len(obstacles_now):
            obstacles_next = 2 * obstacles_now - self._previous_obstacles  # eq. (23)
        else:
            obstacles_next = obstacles_now
        self._previous_obstacles = obstacles_now
        #: Obstacle centres predicted by eq. (23) for the end of this step, t_n + Δt (M, 2).
        self.predicted_obstacles = obstacles_next
        positions = pose[:, :2].astype(float)
        headings = pose[:, 2].astype(float)
        previous = fields["last_command"].astype(float)
        goals = positions + fields["goal_offset"].astype(float)
        speeds = self._speeds(fields, radii)
        static = self._arrived_positions(playing, anchor, mates[0])
        walls = self._sensed_points(fields)
        state = TeamState(positions, headings, previous, speeds, goals, static, obstacles_next, walls)
        losses, _, _ = loss_tensor(state, self.rates, self.dt, self.delay, self.gains)
        if len(agents) == 1:
            choice = (int(np.argmin(losses[0])),)
            self.branch_counts["single"] += 1
        else:
            result = arbitrate(losses, selection=self.selection)
            choice = tuple(int(a) for a in result.actions)
            self.branch_counts[result.branch] += 1
        self.decision_times.append(time.perf_counter() - started)
        return {agent: choice[i] for i, agent in enumerate(agents)}

    def _arrived_positions(self, playing: list[int], anchor: np.ndarray, mates: np.ndarray) -> np.ndarray:
        """Positions (S, 2) of the robots that no longer play, from the first playing robot's observation."""
        if len(playing) == self.n_robots:
            return np.zeros((0, 2))
        # Every robot's position: the first playing robot's pose plus its mates' offsets.
        everyone = np.zeros((self.n_robots, 2))
        everyone[playing[0]] = anchor
        everyone[self._others[playing[0]]] = anchor + mates[:, :2]
        absent = np.ones(self.n_robots, dtype=bool)
        absent[playing] = False
        return everyone[absent]

    def _team_fields(self, observations: Mapping[str, Any], agents: list[str]) -> dict[str, np.ndarray]:
        """The observation fields of ``agents`` stacked on a leading robot axis (flat or dict observations)."""
        if isinstance(observations[agents[0]], Mapping):
            return {name: np.stack([np.asarray(observations[a][name]) for a in agents]) for name in self.observation_fields}
        return self.env.decode(np.array([observations[a] for a in agents]))

    def _sensed_points(self, fields: dict[str, np.ndarray]) -> list[np.ndarray]:
        """Per robot, the world points where its proximity rays hit something (walls included).

        The paper's workspace has no walls; here whatever the ring senses repels the robot
        like an obstacle (eq. 21), so robots do not drive into the arena's walls. ``fields``
        are stacked over the robots (:meth:`_team_fields`).
        """
        pose, proximity = fields["pose"].astype(float), fields["proximity"]
        hits = proximity < self._sensor_range
        angles = pose[:, 2:3] + self._ray_angles
        reach = fields["radius"] + proximity  # float32, as radius + proximity of one robot
        points = np.empty(proximity.shape + (2,))
        points[:, :, 0] = pose[:, 0:1] + reach * np.cos(angles)
        points[:, :, 1] = pose[:, 1:2] + reach * np.sin(angles)
        seen_any = hits.any(axis=1).tolist()
        return [points[i][hits[i]] if seen_any[i] else _NO_POINTS for i in range(len(pose))]

    def _speeds(self, fields: dict[str, np.ndarray], radii: np.ndarray) -> np.ndarray:
        """Linear velocities by eq. (12) of the robots of stacked ``fields``, measuring L_min exactly as the env does.

        The batched form of :func:`teamgym.control.heading.nearest_gap` on every robot's own
        observation, with the same arithmetic (same values, bit for bit).
        """
        radius, mates, obstacles = fields["radius"], fields["mates"], fields["obstacles"]
        offsets = np.concatenate([mates[:, :, :2], obstacles[:, :, :2]], axis=1, dtype=float)
        distance = np.hypot(offsets[:, :, 0], offsets[:, :, 1])
        # Centre distance minus 2r (team mates) or r + bounding radius (obstacles, summed in float32).
        bounds = np.empty(distance.shape)
        bounds[:, : mates.shape[1]] = 2 * radius
        bounds[:, mates.shape[1] :] = radius + radii
        gaps = distance - bounds
        proximity = fields["proximity"]
        seen = proximity < self._sensor_range
        if self._speed_rule == "ahead":
            theta = fields["pose"][:, 2].astype(float)
            direction = np.empty((len(theta), 2, 1))
            direction[:, 0, 0] = np.cos(theta)
            direction[:, 1, 0] = np.sin(theta)
            norm = np.sqrt(np.add.reduce(offsets * offsets, axis=2))
            gaps = np.where((offsets @ direction)[:, :, 0] > AHEAD_COS * norm, gaps, np.inf)
            seen &= self._rays_ahead
        nearest = np.minimum(np.where(seen, proximity, np.inf).min(axis=1).astype(float), gaps.min(axis=1, initial=np.inf))
        goal = fields["goal_offset"]
        return self.heuristic.speed(np.hypot(goal[:, 0], goal[:, 1]).astype(float), nearest)

    def _speed(self, obs: dict[str, np.ndarray], radii: np.ndarray) -> float:
        """Linear velocity by eq. (12) of one robot from its decoded observation (see :meth:`_speeds`)."""
        return float(self._speeds({name: np.asarray(obs[name])[None] for name in self.observation_fields}, radii)[0])
