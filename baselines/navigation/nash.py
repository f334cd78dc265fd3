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
from typing import Any

import numpy as np

from baselines.game import arbitrate
from baselines.navigation.game import ForceGains, TeamState, loss_tensor
from baselines.policy import Policy
from teamgym.control.heading import nearest_gap
from teamgym.envs.navigation.actions import HeadingAction


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
        The modelled T0 in seconds; defaults to the env's ``actuation_delay`` (the
        worst-case delay the system designer knows).
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
        self.selection = selection
        self.n_robots = env.config.n_robots
        self._others = [[j for j in range(self.n_robots) if j != i] for i in range(self.n_robots)]
        self._ray_angles = np.asarray(env.ring.angles, dtype=float)
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
        env = self.env
        agents = sorted(observations, key=env.possible_agents.index)
        playing = [env.possible_agents.index(a) for a in agents]
        fields = {a: env.decode(observations[a]) for a in agents}
        first = fields[agents[0]]
        anchor = first["pose"][:2].astype(float)
        # Every robot's position, from the first observation (own pose plus mates' offsets).
        everyone = np.zeros((self.n_robots, 2))
        everyone[playing[0]] = anchor
        everyone[self._others[playing[0]]] = anchor + first["mates"][:, :2]
        obstacles_now = anchor + first["obstacles"][:, :2] if len(first["obstacles"]) else np.zeros((0, 2))
        radii = first["obstacles"][:, 4] if len(first["obstacles"]) else np.zeros(0)
        if self._previous_obstacles is not None and len(self._previous_obstacles) == len(obstacles_now):
            obstacles_next = 2 * obstacles_now - self._previous_obstacles  # eq. (23)
        else:
            obstacles_next = obstacles_now
        self._previous_obstacles = obstacles_now
        #: Obstacle centres predicted by eq. (23) for the end of this step, t_n + Δt (M, 2).
        self.predicted_obstacles = obstacles_next
        positions = np.array([fields[a]["pose"][:2] for a in agents], dtype=float)
        headings = np.array([fields[a]["pose"][2] for a in agents], dtype=float)
        previous = np.array([fields[a]["last_command"] for a in agents], dtype=float)
        goals = positions + np.array([fields[a]["goal_offset"] for a in agents], dtype=float)
        speeds = np.array([self._speed(fields[a], radii) for a in agents])
        static = np.array([everyone[j] for j in range(self.n_robots) if j not in playing]).reshape(-1, 2)
        walls = self._sensed_points(agents, fields)
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

    def _sensed_points(self, agents: list[str], fields: dict[str, dict[str, np.ndarray]]) -> list[np.ndarray]:
        """Per robot, the world points where its proximity rays hit something (walls included).

        The paper's workspace has no walls; here whatever the ring senses repels the robot
        like an obstacle (eq. 21), so robots do not drive into the arena's walls.
        """
        points = []
        for agent in agents:
            obs = fields[agent]
            x, y, theta = (float(v) for v in obs["pose"])
            radius = float(obs["radius"][0])
            hits = obs["proximity"] < self._sensor_range
            angles = theta + self._ray_angles[hits]
            reach = radius + obs["proximity"][hits]
            points.append(np.column_stack([x + reach * np.cos(angles), y + reach * np.sin(angles)]))
        return points

    def _speed(self, obs: dict[str, np.ndarray], radii: np.ndarray) -> float:
        """Linear velocity by eq. (12), measuring L_min exactly as the env does for ``heading`` actions."""
        radius = float(obs["radius"][0])
        mates, obstacles = obs["mates"], obs["obstacles"]
        offsets = np.concatenate([mates[:, :2], obstacles[:, :2]]).astype(float)
        distance = np.hypot(offsets[:, 0], offsets[:, 1])
        gaps = distance - np.concatenate([np.full(len(mates), 2 * radius), radius + radii])
        nearest = nearest_gap(
            offsets, gaps, float(obs["pose"][2]), obs["proximity"], self._ray_angles, self._sensor_range, self._speed_rule
        )
        return float(self.heuristic.speed(float(np.hypot(*obs["goal_offset"])), nearest))
