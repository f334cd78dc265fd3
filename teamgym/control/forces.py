"""Virtual forces of paper 001, eqs. (15), (19), (21): attraction to the goal, repulsion from objects.

    F_a,i   = k_a / |g_i − x_i|² · (g_i − x_i) / |g_i − x_i|                 (15)
    F_r,i,j = k_r (1/L − 1/L0)² · (x_i − x_j) / L     if L = |x_i − x_j| < L0   (19)
    F_b,i,j = k_rb (1/L − 1/L0)² · (x_i − x_b) / L    if L = |x_i − x_b| < L0   (21)

and 0 beyond the influence distance L0. Shared by the ``nash`` controller
(:mod:`baselines.navigation.game`, which evaluates them at predicted poses) and
Navigation-v0's ``virtual_forces`` observation option (at the current pose).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ForceGains", "attraction", "repulsion"]

#: Distances are clamped to at least this (m), so a force at distance 0 stays finite.
MIN_DISTANCE = 1e-6


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


def repulsion(dx: np.ndarray, dy: np.ndarray, gain: float | np.ndarray, influence: float) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the forces of eqs. (19)/(21) for offsets (dx, dy) pointing from the source to the robot."""
    distance = np.sqrt(dx * dx + dy * dy)
    safe = np.maximum(distance, MIN_DISTANCE)
    magnitude = np.where(distance < influence, gain * (1.0 / safe - 1.0 / influence) ** 2, 0.0)
    return magnitude * dx / safe, magnitude * dy / safe


def attraction(gx: np.ndarray, gy: np.ndarray, gain: float) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the force of eq. (15) for goal offsets (gx, gy) = goal − position."""
    safe = np.maximum(np.sqrt(gx * gx + gy * gy), MIN_DISTANCE)
    scale = gain / safe**2
    return scale * gx / safe, scale * gy / safe
