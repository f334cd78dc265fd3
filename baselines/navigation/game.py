"""The navigation game of paper 001, section 4: predicted poses, virtual forces, losses.

Given the team's state, each robot i chooses one of K angular velocities ω_k (eq. 11; its
linear velocity v_i comes from eqs. 12–13 and does not depend on the choice). The loss of
robot i for a joint decision (d_1 … d_N) is

    I_i = −|F_i| cos(arg F_i − Θ̂_i)                                           (25)

with F_i = F_a,i + Σ_j F_r,i,j + Σ_j F_b,i,j (eqs. 18, 24). ``|F| cos(arg F − Θ̂)`` is the
projection of F on the predicted heading, F · (cos Θ̂, sin Θ̂), which is linear in F; so
the loss tensor splits into a part that depends on d_i alone (attraction, obstacles) plus
one pairwise part per team mate (eq. 19) and is built by broadcasting, without a loop over
joint actions.

Readings of garbled or silent text (see docs/navigation.md):
* eq. (17): the second line starts ``ŷ = x_i + …`` in the text; we read ``y_i``. Poses
  are predicted as written: the previous command acts for T0, then the new one for
  Δt − T0, each phase moving along the heading reached at its end.
* eq. (16)/(22): distances between centres (points), as the paper writes them.
* Directions (Fig. 1, missing): the attraction points from the predicted position to the
  goal, a repulsion points from the other robot's (obstacle's) predicted position to the
  robot's predicted position.
* Obstacle prediction, eq. (23): x̂_b = 2 x_b(t_n) − x_b(t_{n−1}) needs the previous
  position; at the first step of an episode the current position is used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ForceGains:
    """Gains and distances of eqs. (15), (19), (21) (SI units).

    The paper gives no values. Defaults chosen by sweeps on held-out seeds of the obstacle
    experiment (5 robots, 2 obstacles, Δt = 0.2 s; seeds 0–99 are kept for the reported
    results): k_a = 0.5, k_r = 1, k_rb = 8 (obstacles move without negotiating; on seeds
    100–199 k_rb = 2, 4, 8, 16 gave 85, 85, 90, 90% success in the walled arena). L0 = 0.45 m
    from a sweep on 600 seeds (100–199 and 700–1199) in both the walled and the open
    workspace: L0 = 0.35, 0.45, 0.55 m gave 83.8, 85.0, 83.7% walled and 95.2, 97.3, 97.8%
    open (0.65 m: 97.8%, 0.8 m: 98.3% open). An earlier sweep on seeds 100–199 alone (walled)
    had reported 79% for L0 = 0.45 m.
    """

    k_a: float = 0.5
    k_r: float = 1.0
    k_rb: float = 8.0
    influence: float = 0.45


@dataclass
class TeamState:
    """What the arbiter knows at t_n, for the N playing robots and M obstacles.

    ``positions`` (N, 2), ``headings`` (N,), ``previous`` (N, 2) the previous controls
    (v, ω), ``speeds`` (N,) the linear velocity of eq. (12) for this step, ``goals`` (N, 2),
    ``static_points`` (S, 2) robots that do not play (arrived), ``obstacles`` (M, 2) the
    obstacles' predicted centres (eq. 23), ``sensed`` per robot an array (P_i, 2) of points
    its proximity sensors hit (walls), which repel it like obstacles (eq. 21).
    """

    positions: np.ndarray
    headings: np.ndarray
    previous: np.ndarray
    speeds: np.ndarray
    goals: np.ndarray
    static_points: np.ndarray
    obstacles: np.ndarray
    sensed: list[np.ndarray] | None = None


def predict_poses(state: TeamState, rates: np.ndarray, dt: float, delay: float) -> tuple[np.ndarray, np.ndarray]:
    """Predicted positions (N, K, 2) and headings (N, K) after Δt, eqs. (17) and (26)."""
    x, y = state.positions[:, 0:1], state.positions[:, 1:2]
    theta = state.headings[:, None]
    v_prev, w_prev = state.previous[:, 0:1], state.previous[:, 1:2]
    v = state.speeds[:, None]
    first = theta + w_prev * delay
    heading = first + rates[None, :] * (dt - delay)
    px = x + v_prev * delay * np.cos(first) + v * (dt - delay) * np.cos(heading)
    py = y + v_prev * delay * np.sin(first) + v * (dt - delay) * np.sin(heading)
    return np.stack([px, py], axis=-1), heading


def _repulsion(offset: np.ndarray, gain: float, influence: float) -> np.ndarray:
    """Force vectors of eqs. (19)/(21) for offsets pointing from the source to the robot."""
    distance = np.sqrt(np.sum(offset * offset, axis=-1, keepdims=True))
    safe = np.maximum(distance, 1e-6)
    magnitude = np.where(distance < influence, gain * (1.0 / safe - 1.0 / influence) ** 2, 0.0)
    return magnitude * offset / safe


def loss_tensor(
    state: TeamState, rates: np.ndarray, dt: float, delay: float, gains: ForceGains
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Losses of eq. (25) for every joint decision: array of shape (N, K, …, K).

    Also returns the predicted positions (N, K, 2) and headings (N, K).
    """
    n, k = len(state.positions), len(rates)
    predicted, heading = predict_poses(state, rates, dt, delay)
    unit = np.stack([np.cos(heading), np.sin(heading)], axis=-1)  # (N, K, 2)
    to_goal = state.goals[:, None, :] - predicted
    goal_distance = np.sqrt(np.sum(to_goal * to_goal, axis=-1, keepdims=True))
    safe = np.maximum(goal_distance, 1e-6)
    attraction = gains.k_a / safe**2 * to_goal / safe  # eq. (15), towards the goal
    own = attraction
    if len(state.static_points):
        offset = predicted[:, :, None, :] - state.static_points[None, None, :, :]
        own = own + _repulsion(offset, gains.k_r, gains.influence).sum(axis=2)
    if len(state.obstacles):
        offset = predicted[:, :, None, :] - state.obstacles[None, None, :, :]
        own = own + _repulsion(offset, gains.k_rb, gains.influence).sum(axis=2)
    if state.sensed is not None:
        for i, points in enumerate(state.sensed):
            if len(points):
                offset = predicted[i, :, None, :] - points[None, :, :]
                own[i] = own[i] + _repulsion(offset, gains.k_rb, gains.influence).sum(axis=1)
    own_loss = -np.sum(own * unit, axis=-1)  # (N, K)
    # Pairwise part: robot i's repulsion from j for (d_i, d_j), projected on i's heading.
    offset = predicted[:, None, :, None, :] - predicted[None, :, None, :, :]  # (N, N, K, K, 2)
    pair = _repulsion(offset, gains.k_r, gains.influence)
    pair_loss = -np.sum(pair * unit[:, None, :, None, :], axis=-1)  # (N, N, K_i, K_j)
    losses = np.zeros((n,) + (k,) * n)
    for i in range(n):
        shape = [1] * n
        shape[i] = k
        total = own_loss[i].reshape(shape)
        for j in range(n):
            if j == i:
                continue
            pair_shape = [1] * n
            pair_shape[i] = k
            pair_shape[j] = k
            # Axes of pair_loss[i, j] are (d_i, d_j); the joint tensor orders axes by player.
            block = pair_loss[i, j] if i < j else pair_loss[i, j].T
            total = total + block.reshape(pair_shape)
        losses[i] = total
    return losses, predicted, heading
