"""Paper 000's exploration planner: one N-person team game per planning stage (sections 3–4).

At every stage (a ``step()`` of ``Exploration-v0`` with operator actions, i.e. whenever a
robot completes or fails a task, Fig. 5) robot i chooses among its admissible operators
A_i(x_i) (eq. 5, the action mask). Operator a takes robot i from x_i^n to x_i^{n+1} (eq. 6)
and the team cost of a joint choice is

    I(a_1..a_N) = −I_R + I_E + I_D                                                    (7)
    I_R = Σ_i R_i,  R_i = R / k if x_i^{n+1} ∈ M_G, x_i^{n+1} ∉ M_V, else 0             (8)
    I_E = Σ_i w(x_i^n, x_i^{n+1})                                                      (9)
    I_D = Σ_i D_min,i,  D_min,i = min_{u ∈ M_U} cost of p_min(x_i^{n+1}, u)          (10–11)

with k the number of robots whose actions lead to the same object and w the edge costs of
eq. (3) (:mod:`teamgym.maps.topology`). Every robot minimises the same I (a team problem),
so the game is handed to the shared solver (:func:`baselines.game.arbitrate`) with
I_i = I for all i: pure Nash equilibria (eq. 12), of which the arbiter's cost C = N·I picks
the global minimum, eq. (13).

Choices where the paper is silent (docs/exploration.md; tests/baselines/test_nash_explore.py):

* **The "nearest" unexplored object of eq. (11)** (the paper puts "nearest" in quotes). M_U
  is evaluated in the state the joint action leads to (sectors some robot enters in this
  stage are explored for everyone), and the robots' nearest objects are distinct: I_D is
  the smallest Σ_i cost(x_i^{n+1}, u_i) over assignments of distinct unexplored objects u_i
  to as many robots as there are objects; robots left without one add 0
  (``unexplored="assigned"``, default). With plain per-robot nearest objects two robots
  heading for the same room both count it (``"after"``: M_U after the action; ``"before"``:
  M_G \\ M_V of stage n, the most literal reading). All three are compared in
  ``experiments/paper000_exploration.py ablation``; "assigned" needs the fewest stages and
  is the only one that lets a robot with nothing left to do wait, as the paper's robots do.
* **Wait.** Eq. (9) has no w(x, x); we charge ``wait_cost`` (1 cm of travel) for idling, so
  that a move along a cheapest path to the nearest unexplored sector (which lowers I_D by
  exactly what it adds to I_E) is preferred to waiting, and waiting wins whenever moving
  does not help.
* **Continuing a task.** For the operator a robot is still executing, w(x_i^n, x_i^{n+1}) is
  the cheapest path cost when the two are no longer adjacent (e.g. a GoTo passing a door
  circle).
* **Eq. (3) is lost.** ``door_reading`` picks the reading of the door costs
  (:mod:`teamgym.maps.topology`): ``"per-attempt"`` (default), w = L / ((1 − c) o), or
  ``"return-trip"``, w = L (2 − o) / ((1 − c) o), where each failed attempt also costs the way
  back. Section 5.3 explains robot 1's short part in Table 1 by D3,6 being "modeled as the one
  that is almost for sure closed" (o = 0.2): with the first reading robot 1 still tries D3,6
  on the rebuilt office ``office12-table1``, with the second it does not, as in Table 1.
* **R** is not given. With M_U taken after the action, entering a sector removes it from
  the robots' searches, so I_D can grow by up to N times the map's cost diameter; with R
  smaller than that the team can prefer waiting forever (we saw it with R = 1 and R = 5 on
  office12). Default R = (N + 1) × diameter (12.8 m-equivalents for three robots on
  office12), which rules that out.

Centralisation: the planner is the paper's coordinator, which knows every robot's place and
the shared world model; it acts on the robots' observations and action masks only.
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import Any

import numpy as np

from baselines.exploration.planning import TEAM_VIEW_FIELDS, TeamView, check_operator_env, team_view
from baselines.game import arbitrate
from baselines.policy import Policy
from teamgym.maps.topology import TopologicalModel, check_door_reading

#: Largest joint-action set the planner enumerates (product of the admissible-set sizes).
MAX_JOINT_ACTIONS = 200_000
#: Finite stand-in for the infinite cost of an unreachable target (the solver needs finite losses).
UNREACHABLE = 1e6


class NashExplore(Policy):
    """Game-theoretic exploration planner of paper 000 (see the module docstring).

    Parameters
    ----------
    reward:
        R of eq. (8); None: :meth:`default_reward`.
    wait_cost:
        w(x, x) charged for Wait() in eq. (9).
    unexplored:
        ``"assigned"``, ``"after"`` or ``"before"``: the reading of eq. (11) (module docstring).
    selection:
        ``"arbiter"`` (eqs. 30–31 of the shared solver: the global minimum) or ``"first"``
        (the lexicographically first pure equilibrium, which may be only person-by-person
        optimal).
    door_reading:
        ``"per-attempt"`` or ``"return-trip"``: the reading of eq. (3)'s door costs
        (:data:`teamgym.maps.topology.DOOR_READINGS`, module docstring).
    """

    name = "nash-explore"
    env_ids = ("Exploration-v0",)
    observation_fields = TEAM_VIEW_FIELDS
    required_config = {"action_type": "operator"}

    def __init__(
        self,
        env: Any,
        reward: float | None = None,
        wait_cost: float = 0.01,
        unexplored: str = "assigned",
        selection: str = "arbiter",
        door_reading: str = "per-attempt",
    ) -> None:
        super().__init__(env)
        check_operator_env(env, "nash-explore")
        check_door_reading(door_reading)
        if unexplored not in ("assigned", "after", "before"):
            raise ValueError(f"unexplored must be 'assigned', 'after' or 'before', got {unexplored!r}")
        if selection not in ("arbiter", "first"):
            raise ValueError(f"selection must be 'arbiter' or 'first', got {selection!r}")
        if not ((reward is None or reward > 0) and wait_cost >= 0):
            raise ValueError(f"need reward > 0 and wait_cost >= 0, got {reward!r}, {wait_cost!r}")
        self.model = TopologicalModel(env.map, door_reading)
        self.reward = self.default_reward(self.model, env.config.n_robots) if reward is None else float(reward)
        self.wait_cost = float(wait_cost)
        self.unexplored = unexplored
        self.selection = selection
        self.last_game: dict[str, Any] = {}

    @staticmethod
    def default_reward(model: TopologicalModel, n_robots: int) -> float:
        """R = (N + 1) × the largest finite sector-to-sector path cost of the map's prior model.

        Entering a sector removes it from M_U for every robot, so each robot's D_min may grow
        by up to that diameter; a larger R keeps exploring a sector better than waiting.
        """
        costs = model.path_costs()[: model.n_sectors, : model.n_sectors]
        return (n_robots + 1) * float(costs[np.isfinite(costs)].max(initial=1.0))

    def act(self, observations: dict[str, np.ndarray], infos: dict[str, dict] | None = None) -> dict[str, int]:
        return self.decide(team_view(self.env, self.model, observations, infos))

    def decide(self, view: TeamView) -> dict[str, int]:
        """The team's operators for one planning stage (eqs. 7–13)."""
        candidates = [np.flatnonzero(mask) for mask in view.masks]
        cost = self.team_cost(view, candidates)
        losses = np.broadcast_to(cost, (len(view.agents), *cost.shape))
        result = arbitrate(losses, selection=self.selection)
        choice = {a: int(candidates[i][result.actions[i]]) for i, a in enumerate(view.agents)}
        self.last_game = {"cost": cost, "candidates": candidates, "result": result, "view": view}
        return choice

    def team_cost(self, view: TeamView, candidates: list[np.ndarray]) -> np.ndarray:
        """I of eq. (7) for every joint action, shape (K_1, ..., K_N) over the candidate lists."""
        shape = tuple(len(c) for c in candidates)
        total = math.prod(shape)
        if total > MAX_JOINT_ACTIONS:
            raise ValueError(f"{total} joint actions exceed the planner's limit of {MAX_JOINT_ACTIONS}; use fewer robots")
        n = len(candidates)
        ops = view.operators
        places = view.places
        nxt = [np.array([ops.next_place(int(a), int(places[i])) for a in candidates[i]]) for i in range(n)]
        energy = [self._energy(view, i, candidates[i], nxt[i]) for i in range(n)]
        joint_next = np.array(list(itertools.product(*nxt)), dtype=int).reshape(total, n)
        joint_energy = np.array(list(itertools.product(*energy)), dtype=float).reshape(total, n)
        n_sectors = view.model.n_sectors
        open_goal = np.zeros(view.costs.shape[0], dtype=bool)
        open_goal[:n_sectors] = view.goal & ~view.visited
        explores = open_goal[joint_next]  # (M, N): robot i enters an unexplored goal sector
        same = joint_next[:, :, None] == joint_next[:, None, :]
        k = same.sum(axis=2)
        i_r = np.where(explores, self.reward / k, 0.0).sum(axis=1)  # eq. (8)
        i_e = joint_energy.sum(axis=1)  # eq. (9)
        i_d = self._distance_term(view, joint_next)  # eqs. (10)-(11)
        return (-i_r + i_e + i_d).reshape(shape)

    def _energy(self, view: TeamView, i: int, candidates: np.ndarray, nxt: np.ndarray) -> np.ndarray:
        """w(x_i^n, x_i^{n+1}) per candidate (``wait_cost`` for Wait, path cost for a continued task)."""
        place = int(view.places[i])
        out = np.empty(len(candidates))
        for c, (op, target) in enumerate(zip(candidates.tolist(), nxt.tolist())):
            if op == 0:
                out[c] = self.wait_cost
            else:
                w = view.model.cost(place, target)
                out[c] = w if math.isfinite(w) else view.costs[place, target]
        return np.where(np.isfinite(out), out, UNREACHABLE)

    def _distance_term(self, view: TeamView, joint_next: np.ndarray) -> np.ndarray:
        """I_D of eq. (11) for every joint action, shape (M,)."""
        unexplored = view.unexplored  # sector indices of M_G \\ M_V
        if unexplored.size == 0:
            return np.zeros(len(joint_next))
        to_u = view.costs[joint_next][:, :, unexplored]  # (M, N, U)
        if self.unexplored != "before":
            entered = (joint_next[:, :, None] == unexplored[None, None, :]).any(axis=1)  # (M, U)
            to_u = np.where(entered[:, None, :], np.inf, to_u)
        if self.unexplored == "assigned":
            return assignment_cost(to_u)
        nearest = to_u.min(axis=2)
        return np.where(np.isfinite(nearest), nearest, 0.0).sum(axis=1)


@functools.lru_cache(maxsize=64)
def _injections(n: int, m: int) -> np.ndarray:
    """All injective maps from n robots to m columns, shape (K, n)."""
    return np.array(list(itertools.permutations(range(m), n)), dtype=np.intp).reshape(-1, n)


def assignment_cost(costs: np.ndarray) -> np.ndarray:
    """Σ_i D_min,i with robots taking distinct objects: min over injective assignments, per joint action.

    ``costs`` (M, N, U) holds the path cost from each robot's next place to each unexplored
    object (inf: not available). As many robots as possible get an object (min(N, available));
    the others contribute 0. Exact enumeration for small problems, else a greedy matching.
    """
    m, n, u = costs.shape
    big = 1e3 * (1.0 + float(np.nanmax(np.where(np.isfinite(costs), costs, 0.0))))
    padded = np.concatenate([np.where(np.isfinite(costs), costs - big, np.inf), np.zeros((m, n, n))], axis=2)
    tuples = _injections(n, u + n)
    if len(tuples) * m <= 4_000_000:
        rows = np.arange(n)[None, :]
        totals = padded[:, rows, tuples].sum(axis=2)  # (M, K)
        best = totals.min(axis=1)
    else:
        best = np.array([_greedy_assignment(padded[k]) for k in range(m)])
    used = np.round(-best / big)  # objects assigned (each contributed −big)
    return best + used * big


def _greedy_assignment(cost: np.ndarray) -> float:
    cost = cost.copy()
    total = 0.0
    for _ in range(cost.shape[0]):
        i, j = np.unravel_index(np.argmin(cost), cost.shape)
        total += cost[i, j]
        cost[i, :] = np.inf
        if j < cost.shape[1] - cost.shape[0]:
            cost[:, j] = np.inf
    return total
