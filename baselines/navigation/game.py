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

import functools
from dataclasses import dataclass

import numpy as np

from teamgym.control.forces import ForceGains
from teamgym.control.forces import repulsion as _repulsion


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
    px, py, heading, _, _ = _predict(state, rates, dt, delay)
    return np.stack([px, py], axis=-1), heading


def _predict(state: TeamState, rates: np.ndarray, dt: float, delay: float) -> tuple[np.ndarray, ...]:
    """Predicted x, y and heading (each (N, K)) by eqs. (17) and (26), and cos and sin of the heading."""
    x, y = state.positions[:, 0:1], state.positions[:, 1:2]
    theta = state.headings[:, None]
    v_prev, w_prev = state.previous[:, 0:1], state.previous[:, 1:2]
    v = state.speeds[:, None]
    first = theta + w_prev * delay
    heading = first + rates[None, :] * (dt - delay)
    cos, sin = np.cos(heading), np.sin(heading)
    px = x + v_prev * delay * np.cos(first) + v * (dt - delay) * cos
    py = y + v_prev * delay * np.sin(first) + v * (dt - delay) * sin
    return px, py, heading, cos, sin


#: Joint tensors of at most this many losses (N · K^N) are assembled by :func:`_assemble_small`.
SMALL_GAME = 1 << 16


def loss_tensor(
    state: TeamState, rates: np.ndarray, dt: float, delay: float, gains: ForceGains
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Losses of eq. (25) for every joint decision: array of shape (N, K, …, K).

    Also returns the predicted positions (N, K, 2) and headings (N, K).

    Works on x and y components. Every repulsion (team mates, robots that arrived, obstacles,
    sensed points) is computed in one batch; forces are summed per source kind in the order
    attraction, arrived robots, obstacles, sensed points, each kind's sources one after the
    other from 0.0, and a projection on the heading is (F_x cos Θ̂ + F_y sin Θ̂) + 0.0: the same
    floating-point operations as summing (…, 2) vectors with numpy's reductions.
    """
    n, k = len(state.positions), len(rates)
    px, py, heading, cos, sin = _predict(state, rates, dt, delay)
    gx, gy = state.goals[:, 0:1] - px, state.goals[:, 1:2] - py
    safe = np.maximum(np.sqrt(gx * gx + gy * gy), 1e-6)
    scale = gains.k_a / safe**2
    own_x, own_y = scale * gx / safe, scale * gy / safe  # eq. (15), towards the goal
    # Offsets from every source to the robot, source first: team mates (N, N, K, K) for eq. (19),
    # arrived robots (S, N, K), obstacles (M, N, K), then each robot's sensed points (P_i, K).
    dx = [px[:, None, :, None] - px[None, :, None, :]]
    dy = [py[:, None, :, None] - py[None, :, None, :]]
    kinds = [gains.k_r]
    for points, gain in ((state.static_points, gains.k_r), (state.obstacles, gains.k_rb)):
        if len(points):
            dx.append(px[None] - points[:, 0, None, None])
            dy.append(py[None] - points[:, 1, None, None])
            kinds.append(gain)
    sensed = [i for i, points in enumerate(state.sensed or ()) if len(points)]
    for i in sensed:
        dx.append(px[i] - state.sensed[i][:, 0:1])
        dy.append(py[i] - state.sensed[i][:, 1:2])
        kinds.append(gains.k_rb)
    if len(dx) == 1:
        fx, fy = _repulsion(dx[0], dy[0], gains.k_r, gains.influence)
        blocks = [(fx, fy)]
    else:
        sizes = [d.size for d in dx]
        gain = np.repeat(kinds, sizes)
        flat_x, flat_y = (np.concatenate([d.ravel() for d in parts]) for parts in (dx, dy))
        fx, fy = _repulsion(flat_x, flat_y, gain, gains.influence)
        starts = np.cumsum([0, *sizes]).tolist()
        blocks = [(fx[a : a + d.size].reshape(d.shape), fy[a : a + d.size].reshape(d.shape)) for d, a in zip(dx, starts)]
    for bx, by in blocks[1 : len(blocks) - len(sensed)]:
        own_x = own_x + np.add.reduce(bx, axis=0)
        own_y = own_y + np.add.reduce(by, axis=0)
    for i, (bx, by) in zip(sensed, blocks[len(blocks) - len(sensed) :], strict=True):
        own_x[i] = own_x[i] + np.add.reduce(bx, axis=0)
        own_y[i] = own_y[i] + np.add.reduce(by, axis=0)
    own_loss = -(own_x * cos + own_y * sin + 0.0)  # (N, K)
    # Pairwise part: robot i's repulsion from j for (d_i, d_j), projected on i's heading.
    pair_x, pair_y = blocks[0]
    pair_loss = -(pair_x * cos[:, None, :, None] + pair_y * sin[:, None, :, None] + 0.0)  # (N, N, K_i, K_j)
    predicted = np.empty(px.shape + (2,))
    predicted[:, :, 0], predicted[:, :, 1] = px, py
    if n * k**n <= SMALL_GAME:
        return _assemble_small(own_loss, pair_loss), predicted, heading
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


def _assemble_small(own_loss: np.ndarray, pair_loss: np.ndarray) -> np.ndarray:
    """The joint loss tensor (N, K, …, K) from own losses (N, K) and pair losses (N, N, K, K).

    For all players at once, player i's losses are summed in the order own_i, b_i0, b_i1, …
    (the order of the general loop in :func:`loss_tensor`, so the sums are the same bit for
    bit), each new partner's axis placed right after d_i (so every addition runs over long
    contiguous rows); one gather then puts the axes in player order.
    """
    n, k = own_loss.shape
    partners, permutation = _assembly_plan(n, k)
    rows = np.arange(n)
    total = own_loss.reshape(n, k, 1)
    for t in range(n - 1):
        block = pair_loss[rows, partners[t]]  # (N, K_i, K_j): [i, d_i, d_j], j player i's t-th partner
        total = (total[:, :, None, :] + block[:, :, :, None]).reshape(n, k, -1)
    return total.reshape(-1).take(permutation).reshape((n,) + (k,) * n)


@functools.lru_cache(maxsize=16)
def _assembly_plan(n: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Each player's partners in summation order (N−1, N) and the gather from the assembly layout to player order.

    Player i's losses are assembled on the axes (d_i, d_{j_{N−2}}, …, d_{j_0}), the partners
    j_0 < j_1 < … in reverse.
    """
    order = [[t if t < i else t + 1 for t in range(n - 1)] for i in range(n)]
    partners = np.array(order, dtype=np.intp).reshape(n, n - 1).T
    positions = np.arange(n * k**n).reshape((n,) + (k,) * n)
    permutation = np.empty_like(positions)
    for i in range(n):
        permutation[i] = positions[i].transpose(np.argsort([i, *order[i][::-1]]))
    permutation = permutation.reshape(-1)
    partners.flags.writeable = permutation.flags.writeable = False  # shared by every call (cached)
    return partners, permutation
