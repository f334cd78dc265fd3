"""Finite observation bounds derived from a config: where bodies can be and how fast they move.

Every observation field of every env has finite bounds (:class:`~teamgym.envs.spaces.Field`),
and :meth:`~teamgym.envs.spaces.ObservationLayout.clip` saturates what an env writes at them
(a reading beyond its sensor's range reads the range), so ``observation_space(agent).contains``
holds for every observation. Kinematic readings use the limits below; they are wide enough
that the recorded rollouts of the default configs never reach them (``tests/envs/test_obs_hashes.py``).

* **Positions**: a walled world keeps every body in ``[0, w] × [0, h]``; without walls a body
  can travel at most ``SATURATION × body_speed × cycle_limit × dt`` beyond each edge.
* **Speeds**: a reading of v saturates at ``SATURATION ×`` the fastest body speed of the
  config (the robot's top speed or that of what may push it), ω at ``SATURATION ×`` the larger
  of the robot's top turn rate and ``body_speed / radius`` (a body at that speed turning the
  robot by its rim). Wheel rotation per step: the rim speed ``v + (L/2) ω`` at those limits.
"""

from __future__ import annotations

import numpy as np

from teamgym.envs.config import EnvConfig, require, require_together
from teamgym.sim.robot import RobotSpec

__all__ = [
    "PROXIMITY_LIMITS",
    "ROUNDING",
    "SATURATION",
    "Limit",
    "region",
    "require_limits",
    "require_ring_noise",
    "speed_limits",
    "wheel_rotation_limit",
]

#: Kinematic readings saturate at this multiple of the config's top speeds.
SATURATION = 4.0
#: Relative slack on bounds that values reach exactly (a speed at its limit), for rounding.
ROUNDING = 1e-6


def region(config: EnvConfig, size: tuple[float, float], walled: bool, speed: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` of the ``(x, y)`` of any body: the world ``size`` if ``walled``, else grown by the farthest travel.

    ``speed`` (m/s) is a top speed beyond ``config.body_speed()`` (a robot's own, say).
    """
    low, high = np.zeros(2), np.asarray(size, dtype=float)
    if not walled:
        reach = SATURATION * max(speed, config.body_speed()) * config.cycle_limit * config.dt
        low, high = low - reach, high + reach
    return low, high


def speed_limits(config: EnvConfig, spec: RobotSpec) -> tuple[float, float]:
    """Saturation of the speed readings ``(v, ω)`` of a robot of ``spec`` (m/s, rad/s)."""
    speed = max(spec.max_wheel_speed, config.body_speed())
    return SATURATION * speed, SATURATION * max(spec.max_turn_rate, speed / spec.radius)


def wheel_rotation_limit(config: EnvConfig, spec: RobotSpec) -> float:
    """Saturation of a wheel's rotation in one control step (rad): a rim at ``v + (L/2) ω`` of :func:`speed_limits`."""
    v, omega = speed_limits(config, spec)
    return (v + 0.5 * spec.wheel_base * omega) * config.dt / spec.wheel_radius


#: A config key's own range ``(low, high, unit)``, checked in ``check`` before any relation.
Limit = tuple[float, float, str]


def require_limits(config: EnvConfig, limits: dict[str, Limit]) -> None:
    """Raise :class:`~teamgym.envs.config.ConfigError` naming the first key of ``limits`` outside its range."""
    for key, (low, high, unit) in limits.items():
        require(
            config, key, low <= getattr(config, key) <= high, f"must be in [{low:g}, {high:g}]" + (f" {unit}" if unit else "")
        )


#: Own ranges of a proximity ring's keys: range finders of at most 10 m.
PROXIMITY_LIMITS: dict[str, Limit] = {"sensor_range": (0.0, 10.0, "m"), "sensor_noise": (0.0, 10.0, "m")}


def require_ring_noise(config: EnvConfig, level: float, keys: tuple[str, ...] = ("sensor_noise", "sensor_range")) -> None:
    """The relation of a ring's noise std ``level`` (m) to ``sensor_range``: a larger std saturates every ray."""
    require_together(
        config,
        keys,
        level <= config.sensor_range,
        f"the proximity noise std {level:g} m must not exceed sensor_range (a larger one saturates every ray at 0 or the range)",
    )
