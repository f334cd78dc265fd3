"""Linear-velocity heuristic of paper 001, eqs. (12)–(13).

With only the angular velocity left to decide (eq. 11), the linear velocity is

    v_i = ½ · v_opt · w_T · (1 + w_R)                                    (12)
    w_T = 1 / (1 + exp(−α (L_T − L_T0)))                                  (13)
    w_R = 1 / (1 + exp(−β (L_min − L_R0)))

where ``L_T`` is the distance to the target and ``L_min`` the distance to the nearest
object. The paper gives no values for α, β, L_T0, L_R0; our choices (documented in
docs/navigation.md): L_T0 = 5 cm and α = 100 m⁻¹, so the robot lands softly (w_T = 0.007 at
the goal, 0.5 at 5 cm, 0.99 at 10 cm); L_R0 = 15 cm and β = 40 m⁻¹, so the speed halves
when an object is much closer than 15 cm and is v_opt beyond about 25 cm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class HeadingHeuristic:
    """Parameters of eqs. (12)–(13); distances in metres, speeds in m/s."""

    v_opt: float = 0.25
    alpha: float = 100.0
    beta: float = 40.0
    target_threshold: float = 0.05
    object_threshold: float = 0.15

    def speed(self, target_distance, nearest_distance):
        """Linear velocity by eq. (12); works on floats and numpy arrays alike."""
        w_t = 1.0 / (1.0 + np.exp(-self.alpha * (np.asarray(target_distance) - self.target_threshold)))
        w_r = 1.0 / (1.0 + np.exp(-self.beta * (np.asarray(nearest_distance) - self.object_threshold)))
        return 0.5 * self.v_opt * w_t * (1.0 + w_r)


#: Objects and rays count as "ahead" within this cosine of the heading (cos 60°).
AHEAD_COS = 0.5


def nearest_gap(
    offsets: np.ndarray,
    gaps: np.ndarray,
    heading: float,
    proximity: np.ndarray,
    ray_angles: np.ndarray,
    sensor_range: float,
    rule: str = "ahead",
) -> float:
    """L_min of eq. (13): the gap to the nearest object, as ``Navigation-v0`` measures it.

    ``offsets`` (k, 2) point from the robot to each object's centre and ``gaps`` (k,) are
    the rim-to-object gaps; ``proximity`` are the ring's readings (a reading at
    ``sensor_range`` means nothing seen and does not count). With ``rule="ahead"`` only
    objects whose centre lies within ±60° of the heading and the rays pointing that way
    (Khepera rays 1–4) count: the paper slows the robot so that it does not run into things;
    slowing down for an object beside or behind lets a 20 cm/s obstacle catch a robot that
    is running away at v_opt/2. ``rule="any"`` counts every object and ray.
    """
    seen = proximity < sensor_range
    if rule == "ahead":
        direction = np.array([np.cos(heading), np.sin(heading)])
        ahead = offsets @ direction > AHEAD_COS * np.linalg.norm(offsets, axis=1) if len(gaps) else None
        gaps = gaps[ahead] if len(gaps) else gaps
        seen &= np.cos(ray_angles) > AHEAD_COS - 1e-9
    nearest = float(proximity[seen].min()) if seen.any() else np.inf
    return min(nearest, float(gaps.min())) if len(gaps) else nearest
