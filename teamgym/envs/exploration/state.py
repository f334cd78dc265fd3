"""``ExplorationArrays``: the per-episode state of K Exploration copies, declared once.

Every array has a leading copy axis ``k``; robot arrays then a row per robot
(``possible_agents`` order), sector arrays a column per sector ``S``, door arrays one per door
``D`` (map order). A single :class:`~teamgym.envs.exploration.env.Exploration` env is the case
K = 1 (row 0 of its own arrays); a :class:`~teamgym.envs.batch.TeamBatch` binds copy ``k`` to
row ``k`` of one shared ``ExplorationArrays``
(:class:`~teamgym.envs.exploration.phases.ExplorationPhases`), which updates sectors, places,
door sightings, the explored set, goals, rewards and observations of all copies in one numpy
pass. Besides these arrays an episode holds only its simulated objects (world, robots; the
doors' true states are the door entities', mirrored in ``door_is_open``) and the task watchers
of the operator action type (:class:`~teamgym.envs.exploration.operators.OperatorAction`).

The team's topological model (eq. 1; ``TopologicalModel.clutter`` and ``door_open``) and the
clutter re-estimate of eq. (2) (``ClutterEstimate.ratio_sum`` and ``count``) read and write
views of a copy's rows (``clutter``, ``door_belief``, ``clutter_sum``, ``clutter_count``).

Methods take ``ks``, a ``slice`` of copies or an index array of them.
"""

from __future__ import annotations

import math

import numpy as np

from teamgym.envs.copy_arrays import CopyArrays

__all__ = ["ExplorationArrays"]


class ExplorationArrays(CopyArrays):
    """Sectors, places, counters, readings, the explored set and the team's beliefs of ``n_copies`` Exploration copies.

    ``clutter_prior`` (S,): the map's clutter coefficients c_i⁰; ``door_prior`` (D,): the opening
    probabilities o_j, where every episode's beliefs start.
    """

    def __init__(
        self,
        n_robots: int,
        ring_width: int,
        sensor_range: float,
        clutter_prior: np.ndarray,
        door_prior: np.ndarray,
        n_copies: int = 1,
    ) -> None:
        self.n_robots, self.ring_width, self.sensor_range = n_robots, ring_width, float(sensor_range)
        self.clutter_prior = np.asarray(clutter_prior, dtype=float).copy()
        self.door_prior = np.asarray(door_prior, dtype=float).copy()
        self.n_sectors, self.n_doors = len(self.clutter_prior), len(self.door_prior)
        self.n_copies = 0
        self.grow(n_copies)

    # -- storage ---------------------------------------------------------------------
    def _allocate(self, k: int) -> dict[str, np.ndarray]:
        n, s, d = self.n_robots, self.n_sectors, self.n_doors
        return {
            # robots (k, N): sector and place x_i (vertex index: sectors, then doors), contacts, task counters
            "sector": np.zeros((k, n), dtype=np.int64),
            "place": np.zeros((k, n), dtype=np.int64),
            "collisions": np.zeros((k, n), dtype=np.int64),
            "hits": np.zeros((k, n), dtype=np.int64),  # contacts of the last control step
            "collided": np.zeros((k, n), dtype=bool),
            "completed": np.zeros((k, n), dtype=np.int64),  # tasks completed / failed (operators)
            "failed": np.zeros((k, n), dtype=np.int64),
            "task_sector": np.zeros((k, n), dtype=np.int64),  # the sector where the robot's task began
            "in_stage": np.zeros((k, n), dtype=bool),  # robots live when the planning stage began
            "proximity": np.full((k, n, self.ring_width), self.sensor_range, dtype=np.float32),
            # sectors (k, S): M_V, the clutter c_i (eq. 2) and its running sums
            "visited": np.zeros((k, s), dtype=bool),
            "clutter": np.tile(self.clutter_prior, (k, 1)),
            "clutter_sum": np.zeros((k, s)),
            "clutter_count": np.zeros((k, s)),
            # doors (k, D): o_j as the team knows it, the doors' true states
            "door_belief": np.tile(self.door_prior, (k, 1)),
            "door_is_open": np.ones((k, d), dtype=bool),
            # the team (k,): explored goals, contacts, explore time, planning stages
            "explored_all": np.zeros(k, dtype=bool),
            "explored_goals": np.zeros(k, dtype=np.int64),
            "newly_explored": np.zeros(k, dtype=np.int64),  # goal sectors explored in the last control step
            "any_hits": np.zeros(k, dtype=bool),  # some ``hits`` row is not 0
            "explore_time": np.full(k, math.nan),
            "stages": np.zeros(k, dtype=np.int64),
            "stage_start": np.zeros(k, dtype=np.int64),  # control cycle at which the stage began
            "stage_ended": np.zeros(k, dtype=bool),  # a task of the stage completed or failed
        }

    def start(self, k: int, door_is_open: np.ndarray) -> None:
        """A new episode in copy ``k``: nothing explored, priors as beliefs, counters cleared, rings read free."""
        self.clear_row(k)
        self.door_is_open[k] = door_is_open

    # -- phases over copies (the operations of the lone env's hooks) -------------------
    def update_places(
        self,
        ks: slice | np.ndarray,
        points: np.ndarray,
        bounds: np.ndarray,
        discs: np.ndarray,
        goal: np.ndarray,
    ) -> None:
        """Sectors, door sightings, places and the explored set of copies ``ks`` from robot centres ``points`` (g, N, 2).

        The operations of :meth:`Exploration._update_state <teamgym.envs.exploration.env.Exploration._update_state>`:
        a robot is in the first sector whose shrunk rectangle ``bounds`` (S, 4: x0, x1, y0, y1) holds
        it strictly, else it keeps its sector; it sees the doors whose disc ``discs`` (D, 3: x, y, r)
        holds it (``|dx| < r``, ``|dy| < r`` and ``√(dx² + dy²) < r``, the same roundings), their
        beliefs become their true states, and its place is the nearest seen door believed open
        (the first in door order on a tie), else its sector. Comparisons and ``+ − × √`` only.
        """
        x, y = points[..., 0, None], points[..., 1, None]
        inside = (x > bounds[:, 0]) & (x < bounds[:, 1]) & (y > bounds[:, 2]) & (y < bounds[:, 3])
        found = inside.any(axis=2)
        sector = np.where(found, inside.argmax(axis=2), self.sector[ks])
        self.sector[ks] = sector
        place = sector
        if self.n_doors:
            dx, dy = x - discs[:, 0], y - discs[:, 1]
            r = discs[:, 2]
            near = (-r < dx) & (dx < r) & (-r < dy) & (dy < r)
            distance = np.sqrt(dx * dx + dy * dy)
            near &= distance < r
            belief = self.door_belief[ks]
            seen = near.any(axis=1)
            if seen.any():
                belief = np.where(seen, self.door_is_open[ks].astype(float), belief)
                self.door_belief[ks] = belief
            usable = near & (belief[:, None, :] > 0)
            nearest = np.where(usable, distance, math.inf).argmin(axis=2)
            place = np.where(usable.any(axis=2), self.n_sectors + nearest, sector)
        self.place[ks] = place
        reached = np.zeros((len(place), self.n_sectors + self.n_doors), dtype=bool)
        np.put_along_axis(reached, place, True, axis=1)
        visited = self.visited[ks]
        fresh = reached[:, : self.n_sectors] & ~visited
        newly = (fresh & goal).sum(axis=1)
        self.newly_explored[ks] = newly
        if fresh.any():
            visited = visited | fresh
            self.visited[ks] = visited
            self.explored_all[ks] = (visited | ~goal).all(axis=1)
            self.explored_goals[ks] += newly

    def check_goals(self, ks: slice | np.ndarray, cycles: np.ndarray, dt: float) -> None:
        """Explore time (s) of copies that have just explored every goal sector (:meth:`Exploration._check_goals`)."""
        new = (self.newly_explored[ks] > 0) & self.explored_all[ks] & np.isnan(self.explore_time[ks])
        if new.any():
            self.explore_time[ks] = np.where(new, cycles * dt, self.explore_time[ks])

    def team_rewards(self, ks: slice | np.ndarray, explore_reward: float, time_penalty: float) -> np.ndarray:
        """``(g,)``: ``explore_reward`` per newly explored goal sector − ``time_penalty`` (before contacts)."""
        return explore_reward * self.newly_explored[ks] - time_penalty
