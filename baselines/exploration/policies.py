"""Reference planners for ``Exploration-v0`` (operator actions): greedy and random admissible.

* ``greedy``: every robot independently heads for its nearest unexplored goal sector (by the
  path costs of eqs. 3 and 10) and takes the first operator of a cheapest path to it; it
  waits only when no unexplored sector is reachable. No coordination.
* ``random-admissible``: a uniformly random admissible operator per robot and stage (Wait
  included), from the action masks in ``infos``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from baselines.exploration.planning import TEAM_VIEW_FIELDS, TeamView, check_operator_env, team_view
from baselines.policy import Policy
from teamgym.maps.topology import TopologicalModel


class GreedyExplore(Policy):
    """Nearest-unexplored-sector exploration without coordination (see the module docstring)."""

    name = "greedy"
    env_ids = ("Exploration-v0",)
    observation_fields = TEAM_VIEW_FIELDS
    required_config = {"action_type": "operator"}

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        check_operator_env(env, "greedy")
        self.model = TopologicalModel(env.map)

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict] | None = None) -> dict[str, int]:
        return self.decide(team_view(self.env, self.model, observations, infos))

    def decide(self, view: TeamView) -> dict[str, int]:
        """Each robot's first operator on a cheapest path to its nearest unexplored goal sector."""
        unexplored = view.unexplored
        actions = {}
        for i, agent in enumerate(view.agents):
            place = int(view.places[i])
            if unexplored.size == 0:
                actions[agent] = 0
                continue
            target = int(unexplored[np.argmin(view.costs[place, unexplored])])
            best, best_cost = 0, math.inf
            for op in np.flatnonzero(view.masks[i]).tolist():
                if op == 0:
                    continue
                nxt = view.operators.next_place(op, place)
                step = view.model.cost(place, nxt)
                cost = (step if math.isfinite(step) else view.costs[place, nxt]) + view.costs[nxt, target]
                if not math.isfinite(cost):
                    continue
                if cost < best_cost - 1e-9 or (abs(cost - best_cost) <= 1e-9 and op == view.running[i]):
                    best, best_cost = op, cost
            actions[agent] = best if math.isfinite(best_cost) else 0
        return actions


class RandomAdmissible(Policy):
    """A uniformly random admissible operator for every robot at every stage."""

    name = "random-admissible"
    env_ids = ("Exploration-v0",)
    required_config = {"action_type": "operator"}

    def __init__(self, env: Any) -> None:
        super().__init__(env)
        check_operator_env(env, "random-admissible")

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict] | None = None) -> dict[str, int]:
        actions = {}
        for agent in observations:
            mask = (infos or {}).get(agent, {}).get("action_mask")
            mask = np.asarray(mask if mask is not None else self.env.action_mask(agent))
            actions[agent] = int(self.np_random.choice(np.flatnonzero(mask)))
        return actions
