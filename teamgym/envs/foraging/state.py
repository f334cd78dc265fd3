"""``ForagingArrays``: Foraging's per-episode state for K env copies, as arrays over copies.

Every array has a leading copy axis ``k``; robot arrays then a row per possible robot
(``possible_agents`` order), target arrays a slot per target. A single
:class:`~teamgym.envs.foraging.env.Foraging` env is the case K = 1 (row 0 of its own arrays);
a :class:`~teamgym.envs.batch.TeamBatch` of Foraging copies binds copy ``k`` to row ``k`` of
one shared ``ForagingArrays`` (:class:`~teamgym.envs.foraging.phases.ForagingPhases`).

The env works on views of its row (``Foraging._use_rows``), written in place: the true poses,
the odometry (estimate x̂, ŷ, θ̂ and certainty Pl, eq. 2), the distance travelled, who is at
which target and for how long, the reward's last distances, the sightings table of the last
sensing phase (the packets' and observations' source, section 2.1 eq. 1), the targets and
when each was finished, and the team's clocks. Besides these arrays an episode holds only its
simulated objects (the world and its bodies), the per-world-model grids of
``observe_world_model`` and caches derived from the arrays (the live targets' indices, the
cameras' view geometry of the poses).
"""

from __future__ import annotations

import numpy as np

from teamgym.envs.copy_arrays import CopyArrays

__all__ = ["ForagingArrays"]


class ForagingArrays(CopyArrays):
    """Robot, target and team state of ``n_copies`` Foraging copies (see the module docstring)."""

    def __init__(self, n_robots: int, n_targets: int, n_slots: int, n_copies: int = 1) -> None:
        if n_robots < 1 or n_targets < 0 or n_slots < 0 or n_copies < 0:
            raise ValueError(
                f"ForagingArrays: n_robots={n_robots} must be >= 1, n_targets={n_targets}, n_slots={n_slots} "
                f"and n_copies={n_copies} >= 0"
            )
        self.n_robots, self.n_targets, self.n_slots = n_robots, n_targets, n_slots
        self.n_copies = 0
        self.grow(n_copies)

    # -- storage ---------------------------------------------------------------------
    def _allocate(self, k: int) -> dict[str, np.ndarray]:
        n, t, d = self.n_robots, self.n_targets, self.n_slots
        return {
            # robots (k, n): truth, odometry (eq. 2), counters, presence at targets
            "pose": np.zeros((k, n, 3)),  # true x, y, θ (θ in [−π, π))
            "estimate": np.zeros((k, n, 3)),  # odometry's x̂, ŷ, θ̂
            "certainty": np.ones((k, n)),  # Pl
            "travelled": np.zeros((k, n)),  # DG (m)
            "at": np.full((k, n), -1, dtype=np.int64),  # target a robot is within reach of, −1 none
            "timer": np.zeros((k, n)),  # time at that target (s)
            "redundant": np.zeros((k, n), dtype=np.int64),  # operations at consumed targets (persist)
            "nearest": np.zeros((k, n)),  # distance to the nearest live target at the last reward (m)
            "nearest_live": np.zeros((k, n)),  # that distance now (0 without live targets)
            # the last sensing phase: each robot's own tuple and detections (Sightings.table) and their count
            "table": np.zeros((k, n, 1 + d, 8), dtype=np.float32),
            "count": np.zeros((k, n), dtype=np.int64),
            # targets (k, T)
            "targets": np.zeros((k, t, 2)),
            "target_live": np.ones((k, t), dtype=bool),
            "target_done_at": np.full((k, t), np.nan),
            # the team (k,)
            "senses": np.zeros(k, dtype=np.int64),  # sensing phases since reset (packet_rate's schedule)
            "first_seen": np.full(k, np.nan),  # TL (s)
            "success": np.zeros(k, dtype=bool),
            "finished_now": np.zeros(k, dtype=np.int64),  # targets finished in this control step
            "any_target": np.zeros(k, dtype=bool),  # whether the last sensing phase detected a target
        }

    def start(self, k: int) -> None:
        """A new episode in copy ``k``: every array at its initial value (the env then places robots and targets)."""
        self.clear_row(k)
