"""The masked recurrent variant (``--algo maskable-recurrent-ppo``): RecurrentPPO with action masks.

sb3-contrib has no masked ``RecurrentPPO``. Here the masks travel in the observation
(:class:`MasksInObservation`) and :class:`MaskedLstmPolicy` masks the logits before any
distribution is used; see :mod:`baselines.rl.recurrent` for the design. Imports sb3-contrib.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from sb3_contrib.common.recurrent.policies import RecurrentActorCriticPolicy
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

__all__ = ["MASKED_LOGIT", "MaskedLstmPolicy", "MasksInObservation", "mask_width"]

#: The logit of a masked action (as sb3-contrib's MaskablePPO: probability 0, finite log-probability).
MASKED_LOGIT = -1e8


def mask_width(action_space: spaces.Space) -> int:
    """Length of a mask of ``action_space`` in MaskablePPO's layout (``n``, or the sum of ``nvec``)."""
    if isinstance(action_space, spaces.Discrete):
        return int(action_space.n)
    if isinstance(action_space, spaces.MultiDiscrete):
        return int(np.sum(action_space.nvec))
    raise ValueError(f"action masks need Discrete or MultiDiscrete actions, not {action_space}")


def _dimensions(action_space: spaces.Space) -> list[int]:
    return [int(action_space.n)] if isinstance(action_space, spaces.Discrete) else [int(n) for n in action_space.nvec.ravel()]


class MasksInObservation(VecEnvWrapper):
    """A VecEnv whose observations end with the slot's action mask (``venv.action_masks()``, as 0/1 floats).

    A finished robot's ``terminal_observation`` gets an all-ones mask (it is only valued,
    never acted on). See the module docstring.
    """

    def __init__(self, venv: VecEnv) -> None:
        space = venv.observation_space
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ValueError(f"masks are appended to flat (1-D Box) observations, not {space}")
        self.width = mask_width(venv.action_space)
        low = np.concatenate([space.low, np.zeros(self.width)]).astype(np.float32)
        high = np.concatenate([space.high, np.ones(self.width)]).astype(np.float32)
        super().__init__(venv, observation_space=spaces.Box(low, high, dtype=np.float32))

    def _with_masks(self, observations: np.ndarray) -> np.ndarray:
        masks = np.asarray(self.venv.action_masks(), dtype=np.float32).reshape(len(observations), self.width)
        return np.concatenate([np.asarray(observations, dtype=np.float32), masks], axis=1)

    def reset(self) -> np.ndarray:
        return self._with_masks(self.venv.reset())

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        observations, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            final = info.get("terminal_observation")
            if final is not None:
                ones = np.ones(self.width, np.float32)
                info["terminal_observation"] = np.concatenate([np.asarray(final, dtype=np.float32), ones])
        return self._with_masks(observations), rewards, dones, infos


class MaskedLstmPolicy(RecurrentActorCriticPolicy):
    """sb3-contrib's LSTM actor-critic with action masks read from the last ``mask_width`` observation values.

    Every distribution the policy builds (``forward``: rollout sampling; ``evaluate_actions``:
    the PPO loss; ``get_distribution``: ``predict``) has the logits of masked actions set to
    :data:`MASKED_LOGIT` (see the module docstring).
    """

    def __init__(self, *args: Any, mask_width: int, **kwargs: Any) -> None:
        self.mask_width = int(mask_width)
        self._masks: Any = None
        super().__init__(*args, **kwargs)
        self._dims = _dimensions(self.action_space)
        if sum(self._dims) != self.mask_width:
            raise ValueError(f"mask_width={self.mask_width} does not fit the action space {self.action_space}")

    def _masked(self, obs: Any, call: Any) -> Any:
        self._masks = obs[..., -self.mask_width :] > 0.5
        try:
            return call()
        finally:
            self._masks = None

    def forward(self, obs: Any, lstm_states: Any, episode_starts: Any, deterministic: bool = False) -> Any:
        return self._masked(obs, lambda: super(MaskedLstmPolicy, self).forward(obs, lstm_states, episode_starts, deterministic))

    def get_distribution(self, obs: Any, lstm_states: Any, episode_starts: Any) -> Any:
        return self._masked(obs, lambda: super(MaskedLstmPolicy, self).get_distribution(obs, lstm_states, episode_starts))

    def evaluate_actions(self, obs: Any, actions: Any, lstm_states: Any, episode_starts: Any) -> Any:
        call = super().evaluate_actions
        return self._masked(obs, lambda: call(obs, actions, lstm_states, episode_starts))

    def _get_action_dist_from_latent(self, latent_pi: Any) -> Any:
        import torch
        from torch.distributions import Categorical

        distribution = super()._get_action_dist_from_latent(latent_pi)
        if self._masks is None:
            return distribution
        masks = self._masks.reshape(len(latent_pi), self.mask_width)
        logits = self.action_net(latent_pi)
        parts = []
        for logit, mask in zip(torch.split(logits, self._dims, dim=1), torch.split(masks, self._dims, dim=1)):
            mask = mask | ~mask.any(dim=1, keepdim=True)  # an all-zero mask (sequence padding) masks nothing
            parts.append(Categorical(logits=torch.where(mask, logit, torch.full_like(logit, MASKED_LOGIT))))
        distribution.distribution = parts[0] if isinstance(self.action_space, spaces.Discrete) else parts
        return distribution
