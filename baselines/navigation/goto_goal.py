"""A simple scripted go-to-goal policy: turn towards the goal, drive, slow down on arrival.

It ignores team mates and obstacles (the reference point every collision-avoiding
policy must beat) and works with every action type of ``Navigation-v0``.
"""

from __future__ import annotations

import numpy as np

from baselines.policy import Policy
from teamgym.envs.actions import VelocityAction, WheelSpeedAction
from teamgym.envs.navigation.actions import HeadingAction
from teamgym.sim.robot import wheel_speeds, wrap_angle


class GoToGoal(Policy):
    """Proportional heading control towards ``goal_offset``.

    ω = k_ω · e (clipped), v = v_cruise · max(0, cos e) · min(1, d / d_slow), with e the
    heading error to the goal and d its distance.
    """

    name = "goto"
    env_ids = ("Navigation-v0",)
    observation_fields = ("pose", "goal_offset")

    def __init__(self, env, v_cruise: float = 0.25, k_omega: float = 4.0, slow_distance: float = 0.1) -> None:
        super().__init__(env)
        self.v_cruise = v_cruise
        self.k_omega = k_omega
        self.slow_distance = slow_distance

    def act(self, observations, infos=None):
        env = self.env
        action_type = env.action_type
        actions = {}
        for agent, obs in observations.items():
            fields = env.decode(obs)
            theta = float(fields["pose"][2])
            dx, dy = (float(v) for v in fields["goal_offset"])
            distance = float(np.hypot(dx, dy))
            error = float(wrap_angle(np.arctan2(dy, dx) - theta))
            if isinstance(action_type, HeadingAction):
                actions[agent] = int(np.argmin(np.abs(action_type.rates - self.k_omega * error)))
                continue
            v = self.v_cruise * max(0.0, np.cos(error)) * min(1.0, distance / self.slow_distance)
            omega = self.k_omega * error
            space = env.action_space(agent)
            if isinstance(action_type, VelocityAction):
                command = np.array([v, omega])
            elif isinstance(action_type, WheelSpeedAction):
                command = np.array(wheel_speeds(v, omega, env.spec_robot.wheel_base))
            else:
                raise TypeError(f"GoToGoal does not support action type {type(action_type).__name__}")
            actions[agent] = np.clip(command, space.low, space.high).astype(space.dtype)
        return actions
