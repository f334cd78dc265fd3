"""What the exploration planners of paper 000 know at a planning stage, read from observations.

The coordinator (section 2, Fig. 1) gathers every robot's place x_i, the explored set M_V,
the goal set M_G and the world model M (the map's topology with the team's current door
beliefs o_j and clutter estimates c_i); :func:`team_view` rebuilds exactly that from the
robots' observations and the action masks in ``infos``. The map's topology is a-priori
knowledge (section 2.1), read from ``env.map``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from teamgym.envs.exploration.operators import OperatorSet
from teamgym.maps.topology import TopologicalModel

#: The observation fields :func:`team_view` decodes.
TEAM_VIEW_FIELDS = ("place", "task", "task_status", "door_belief", "clutter", "visited", "goal")


@dataclass
class TeamView:
    """One planning stage: agents, places (vertex indices), masks, M_V, M_G, model and path costs."""

    agents: list[str]
    places: np.ndarray
    masks: np.ndarray
    running: np.ndarray
    visited: np.ndarray
    goal: np.ndarray
    model: TopologicalModel
    operators: OperatorSet
    costs: np.ndarray

    @property
    def unexplored(self) -> np.ndarray:
        """Sector indices of M_U = M_G \\ M_V."""
        return np.flatnonzero(self.goal & ~self.visited)


def check_operator_env(env: Any, policy: str) -> None:
    """Raise unless ``env`` is Exploration-v0 with ``action_type="operator"``."""
    if getattr(getattr(env, "action_type", None), "name", None) != "operator" or not hasattr(env, "operator_set"):
        raise ValueError(f"{policy} needs Exploration-v0 with action_type='operator'; make the env with action_type='operator'")


def team_view(env: Any, model: TopologicalModel, observations: dict[str, np.ndarray], infos: dict[str, dict] | None) -> TeamView:
    """Decode the live robots' observations into a :class:`TeamView` (``model`` is updated in place)."""
    agents = list(observations)
    fields = {a: env.decode(observations[a]) for a in agents}
    first = fields[agents[0]]
    model.door_open[:] = first["door_belief"]
    model.clutter[:] = first["clutter"]
    places = np.array([int(np.argmax(fields[a]["place"])) for a in agents])
    running = np.array([int(round(float(fields[a]["task"][0]))) for a in agents])
    statuses = [int(np.argmax(fields[a]["task_status"])) for a in agents]
    running[[s != 1 for s in statuses]] = -1  # only an executing task can be continued
    masks = []
    for a in agents:
        info = (infos or {}).get(a, {})
        mask = info.get("action_mask")
        masks.append(np.asarray(mask if mask is not None else env.action_mask(a), dtype=bool))
    return TeamView(
        agents=agents,
        places=places,
        masks=np.array(masks),
        running=running,
        visited=first["visited"] > 0.5,
        goal=first["goal"] > 0.5,
        model=model,
        operators=env.operator_set,
        costs=model.path_costs(),
    )
