"""teamgym envs as Stable-Baselines3 vector envs through SuperSuit; needs the ``supersuit`` extra (docs/scale_out.md).

SuperSuit's ``pettingzoo_env_to_vec_env_v1`` makes one vector-env slot per possible agent and
needs a fixed agent list, so the env is made with ``fixed_agents=True``
(:mod:`teamgym.envs.fixed_agents`; no ``black_death`` wrapper); ``concat_vec_envs_v1`` stacks
``n_copies`` such envs. :class:`SuperSuitVecEnv` then makes the SB3 ``VecEnv`` instead of
SuperSuit's ``base_class="stable_baselines3"`` wrapper, which with SuperSuit 3.11.0 and SB3
2.9 fails on ``model = PPO(..., seed=S)`` (``'ConcatVecEnv' object has no attribute 'seed'``)
and reports ``done = terminated or truncated`` without ``TimeLimit.truncated``. Ours seeds the
first reset (copy ``i`` with ``seed + i``), marks a time-limit end ``TimeLimit.truncated`` (SB3
bootstraps the value there) and, with ``obs_format="masked"``, passes the flat ``observation``
on and keeps the ``action_mask`` for sb3-contrib's ``MaskablePPO`` (``action_masks()``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv


class SuperSuitVecEnv(VecEnv):
    """An SB3 ``VecEnv`` over SuperSuit's gymnasium ``ConcatVecEnv`` of teamgym slots."""

    def __init__(self, venv: Any) -> None:
        self.venv = venv
        space = venv.observation_space
        self.masked = isinstance(space, spaces.Dict) and "action_mask" in space.spaces
        super().__init__(venv.num_envs, space["observation"] if self.masked else space, venv.action_space)
        self._masks = np.ones((self.num_envs, *space["action_mask"].shape), dtype=bool) if self.masked else None
        self._seed: int | None = None
        self._actions: np.ndarray | None = None

    def _flat(self, observations: Any) -> np.ndarray:
        if not self.masked:
            return observations
        self._masks = np.asarray(observations["action_mask"], dtype=bool)
        return observations["observation"]

    def seed(self, seed: int | None = None) -> list[int | None]:
        """Seed the next reset: copy ``i`` of the team env resets with ``seed + i``."""
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def reset(self) -> np.ndarray:
        # Copies start from one pickled env: an unseeded reset would give every copy the same episodes.
        seed = self._seed if self._seed is not None else int(np.random.default_rng().integers(2**31 - 1))
        self._seed = None
        observations, self.reset_infos = self.venv.reset(seed=seed)
        return self._flat(observations)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        observations, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        terminated, truncated = np.asarray(terminated, dtype=bool), np.asarray(truncated, dtype=bool)
        dones = terminated | truncated
        for i in np.flatnonzero(dones).tolist():
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            terminal = infos[i].get("terminal_observation")
            if self.masked and isinstance(terminal, dict):
                infos[i]["terminal_observation"] = terminal["observation"]
        return self._flat(observations), np.asarray(rewards, dtype=np.float32), dones, infos

    def action_masks(self) -> np.ndarray:
        """Every slot's current action mask, (num_envs, n) booleans (``obs_format="masked"`` only)."""
        if self._masks is None:
            raise ValueError("action_masks() needs obs_format='masked'")
        return self._masks.copy()

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> list[Any]:
        if method_name == "action_masks" and self.masked:  # what MaskablePPO calls on a VecEnv
            return list(self.action_masks()[list(self._get_indices(indices))])
        raise AttributeError(f"SuperSuitVecEnv: slots have no method {method_name!r}")

    def has_attr(self, attr_name: str) -> bool:
        return (attr_name == "action_masks" and self.masked) or attr_name == "render_mode"

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        if attr_name != "render_mode":
            raise AttributeError(f"SuperSuitVecEnv: slots have no attribute {attr_name!r}")
        return [self.venv.render_mode for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        raise AttributeError(f"SuperSuitVecEnv: cannot set {attr_name!r} on the slots")

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def close(self) -> None:
        self.venv.close()


def supersuit_vec_env(env_id: str, config: dict[str, Any] | None = None, n_copies: int = 1) -> SuperSuitVecEnv:
    """``n_copies`` of ``env_id`` (``config`` overrides; ``fixed_agents`` set to True) as one SB3 ``VecEnv``, a slot per robot."""
    import supersuit as ss

    import teamgym

    if not isinstance(n_copies, int) or isinstance(n_copies, bool) or n_copies < 1:
        raise ValueError(f"supersuit_vec_env: n_copies={n_copies!r} must be an int >= 1")
    config = dict(config or {})
    if config.get("fixed_agents", True) is not True:
        raise ValueError(f"supersuit_vec_env: fixed_agents={config['fixed_agents']!r}; SuperSuit needs fixed_agents=True")
    env = teamgym.make(env_id, **{**config, "fixed_agents": True})
    return SuperSuitVecEnv(ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), n_copies, num_cpus=0))
