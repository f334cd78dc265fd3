"""Paper 001's discrete heading set as an action type of Navigation-v0.

The speed rule reads the env's ``speed_inputs(agent)``: the distance to the robot's goal and
L_min of eq. (12), the gap to the nearest object that the speed rule considers.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from teamgym.control.heading import HeadingHeuristic
from teamgym.envs.actions import ActionType


class HeadingAction(ActionType):
    """Paper 001's decision set (eq. 11): K angular-velocity levels, v from eqs. (12)–(13).

    Level ``k`` of ``K`` is ``ω_k = −ω_max + 2 ω_max k / (K − 1)``; with K = 5 and
    ω_max = 225 deg/s this is the paper's set {−225, −112.5, 0, 112.5, 225} deg/s.
    """

    name = "heading"

    def __init__(self, levels: int, max_rate_deg: float, heuristic: HeadingHeuristic) -> None:
        if levels < 2:
            raise ValueError(f"HeadingAction needs at least 2 levels, got {levels}")
        self.rates = np.deg2rad(np.linspace(-max_rate_deg, max_rate_deg, levels))
        self.heuristic = heuristic

    def space(self) -> spaces.Discrete:
        return spaces.Discrete(len(self.rates))

    def act(self, env, agent: str, action) -> tuple[float, float]:
        """ω of the chosen level; v from eqs. (12)–(13) with the env's ``speed_inputs(agent)``."""
        target_distance, nearest_distance = env.speed_inputs(agent)
        v = float(self.heuristic.speed(target_distance, nearest_distance))
        return v, float(self.rates[int(action)])
