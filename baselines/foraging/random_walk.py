"""``random-walk``: the no-planning reference for ``Foraging-v0`` (goto_cell actions).

Each robot drives to a uniformly random admissible cell (drawn with the policy's
``np_random``, seeded by :meth:`Policy.reset`) and keeps it until it reaches it (its estimated
position is in that cell) or ``goal_timeout`` s (10) pass. When it sees a target (its own
detections only: no world model, no communication) it goes to the nearest detected target's
cell and stays there while it is at a target (until consumed); it gives up a target it has
not seen for ``goal_timeout`` s unless it is at one.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from baselines.foraging.dmaps import check_goto_cell
from baselines.policy import Policy
from teamgym.envs.foraging.world_model import TARGET

__all__ = ["RandomWalk"]


class RandomWalk(Policy):
    """Random admissible go-to cells; a seen target is approached and held (see the module docstring)."""

    name = "random-walk"
    env_ids = ("Foraging-v0",)
    observation_fields = ("pose_estimate", "detections", "detection_mask", "detection_polar", "at_target")
    required_config = {"action_type": "goto_cell"}

    def __init__(self, env: Any, goal_timeout: float = 10.0) -> None:
        super().__init__(env)
        check_goto_cell(env, "random-walk")
        self.grid = env.config.grid
        self.dt = float(env.config.dt)
        self.goal_timeout = float(goal_timeout)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.steps = 0
        self.goal: dict[str, int] = {}
        self.goal_time: dict[str, float] = {}
        self.target: dict[str, int] = {}
        self.target_time: dict[str, float] = {}

    def act(self, observations: dict[str, Any], infos: dict[str, dict] | None = None) -> dict[str, int]:
        now, grid = self.steps * self.dt, self.grid
        actions = {}
        for agent, obs in observations.items():
            fields = self.env.decode(obs)
            mask = (infos or {}).get(agent, {}).get("action_mask")
            mask = np.ones(grid.n_cells, dtype=np.int8) if mask is None else np.asarray(mask)
            valid = fields["detection_mask"] > 0
            det, polar = fields["detections"][valid], fields["detection_polar"][valid]
            seen = det[:, 0] == TARGET
            if seen.any():
                nearest = det[seen][int(np.argmin(polar[seen, 0]))]
                cell = int(grid.index_of(nearest[1:3].astype(np.int64)))
                if mask[cell]:
                    self.target[agent], self.target_time[agent] = cell, now
            at = bool(fields["at_target"][0] > 0)
            if agent in self.target and not at and now - self.target_time[agent] >= self.goal_timeout - 1e-9:
                del self.target[agent]
            if agent in self.target:
                actions[agent] = self.target[agent]
                if not at and not seen.any():
                    here = int(grid.index_of(grid.cell_of(fields["pose_estimate"][:2])))
                    if here == self.target[agent]:  # reached and nothing there: gone
                        del self.target[agent]
                continue
            here = int(grid.index_of(grid.cell_of(fields["pose_estimate"][:2])))
            goal = self.goal.get(agent, -1)
            expired = now - self.goal_time.get(agent, -np.inf) >= self.goal_timeout - 1e-9
            if goal < 0 or goal == here or expired or not mask[goal]:
                goal = int(self.np_random.choice(np.flatnonzero(mask)))
                self.goal[agent], self.goal_time[agent] = goal, now
            actions[agent] = goal
        self.steps += 1
        return actions
