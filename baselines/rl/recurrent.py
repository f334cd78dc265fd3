"""Recurrent (LSTM) policies: sb3-contrib's ``RecurrentPPO`` with each robot's hidden state carried through an episode.

Training (``python -m baselines.train --algo recurrent-ppo``) uses ``RecurrentPPO`` with its
``MlpLstmPolicy`` on :class:`~baselines.rl.sb3_env.TeamVecEnv` unchanged: every slot is one
robot's episode, and a slot's ``done`` (its robot finished, or a wait for a robot ended) is the
``episode_start`` that zeroes that slot's LSTM state at the next step, so each robot's memory
starts at its episode's first observation and never crosses into another robot's episode.

Evaluation (:class:`~baselines.rl.sb3_policy.SB3Policy`, hence ``baselines.evaluate``,
``baselines.rl.compare``, ``run_episode`` and training's own held-out evaluation) keeps an
:class:`AgentMemory`: one ``(h, c)`` per robot, passed to ``model.predict`` and replaced by
the state it returns, step after step; a robot's first step of an episode is an
``episode_start`` (zero state), and :meth:`AgentMemory.reset` (called by ``SB3Policy.reset``
at every episode start) forgets every robot's state. Without it the LSTM would run from a
zero state at every step, i.e. as a feed-forward net it was never trained as.

Action masks: sb3-contrib has no masked ``RecurrentPPO``, so ``recurrent-ppo`` refuses masked
action types (Exploration's ``operator``, Rendezvous' ``next_place``, ...) in one line
(:func:`masks_refusal`) and ``--algo maskable-recurrent-ppo`` is the small masked variant here:

* :class:`~baselines.rl.masked_recurrent.MasksInObservation` appends each slot's action mask (0/1, MaskablePPO's layout: the
  concatenation of every discrete dimension's mask) to its observation, so the mask is stored
  with the observation in RecurrentPPO's rollout buffer and reaches every mini-batch sequence
  aligned with its step, with no change to the buffer;
* :class:`~baselines.rl.masked_recurrent.MaskedLstmPolicy` (``MlpLstmPolicy`` plus ``mask_width``) reads that tail of the
  observation and sets the logits of masked actions to −10⁸ before the distribution is used,
  in the rollout (sampling), in the update (log-probabilities and entropy of the PPO loss) and
  in ``predict``; a dimension whose mask is all zero (the zero padding of RecurrentPPO's
  sequences, which the loss ignores) is left unmasked. The LSTM and the critic see the mask as
  part of the observation;
* :class:`AgentMemory` appends the env's masks to the observations in evaluation.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["MASKED_RECURRENT", "RECURRENT_ALGORITHMS", "AgentMemory", "is_recurrent", "masks_refusal"]

#: Algorithms whose policy has a hidden state (``model.predict`` takes ``state`` and ``episode_start``).
RECURRENT_ALGORITHMS = frozenset({"recurrent_ppo", "maskable_recurrent_ppo"})
#: The masked variant: RecurrentPPO with :class:`~baselines.rl.masked_recurrent.MaskedLstmPolicy` on
#: :class:`~baselines.rl.masked_recurrent.MasksInObservation`.
MASKED_RECURRENT = "maskable_recurrent_ppo"
#: The saved policy class's module of a ``RecurrentPPO`` model (how a zip without sidecar is recognised).
RECURRENT_POLICY_MODULE = "sb3_contrib.common.recurrent.policies"


def is_recurrent(model: Any) -> bool:
    """Whether ``model``'s policy is recurrent (it has ``lstm_hidden_state_shape``, as sb3-contrib's LSTM policies)."""
    return getattr(getattr(model, "policy", None), "lstm_hidden_state_shape", None) is not None


def masks_refusal(algo: str, env_name: str, action_type: str) -> str:
    """The one-line reason a recurrent ``algo`` cannot train on a masked action type, and what to use instead."""
    return (
        f"{algo} cannot respect the action masks of {env_name} (action_type={action_type!r}): sb3-contrib has no masked "
        "RecurrentPPO, and unmasked it would pick actions the env refuses; use --algo maskable-recurrent-ppo (this "
        "package's masked variant), --algo maskable-ppo (masks, no memory) or an action type without masks"
    )


class AgentMemory:
    """The LSTM state ``(h, c)`` of every robot through one episode, for ``model.predict`` of a recurrent model.

    :meth:`predict` stacks the states of the robots asked for (zeros, with ``episode_start``,
    for a robot not seen since :meth:`reset`), calls ``model.predict`` once and keeps the
    state each robot comes out with. Robots are told apart by name, so a robot that leaves
    ``env.agents`` early neither shifts the others' states nor is asked for again.
    """

    def __init__(self, model: Any) -> None:
        if not is_recurrent(model):
            raise ValueError(f"{type(model).__name__} has no recurrent policy (lstm_hidden_state_shape)")
        self.model = model
        layers, _, hidden = model.policy.lstm_hidden_state_shape
        self._zero = np.zeros((layers, hidden), dtype=np.float32)
        self.states: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        #: The mask length a :class:`~baselines.rl.masked_recurrent.MaskedLstmPolicy` reads at the end of
        #: each observation (0: none).
        self.mask_width = int(getattr(model.policy, "mask_width", 0))

    def reset(self) -> None:
        """Forget every robot's state: the next step of each is an episode start."""
        self.states.clear()

    def predict(
        self, agents: list[str], observations: np.ndarray, deterministic: bool = True, masks: np.ndarray | None = None
    ) -> np.ndarray:
        """Actions of ``agents`` (rows of ``observations``), carrying each one's hidden state to its next call.

        A masked model gets ``masks`` (one row per agent; ``None``: every action admissible) after the observations.
        """
        if self.mask_width:
            rows = np.ones((len(agents), self.mask_width), np.float32) if masks is None else np.asarray(masks, np.float32)
            observations = np.concatenate([np.asarray(observations, dtype=np.float32), rows], axis=1)
        starts = np.array([agent not in self.states for agent in agents], dtype=bool)
        h = np.stack([self.states.get(a, (self._zero, self._zero))[0] for a in agents], axis=1)
        c = np.stack([self.states.get(a, (self._zero, self._zero))[1] for a in agents], axis=1)
        actions, (h, c) = self.model.predict(observations, state=(h, c), episode_start=starts, deterministic=deterministic)
        for i, agent in enumerate(agents):
            self.states[agent] = (np.array(h[:, i]), np.array(c[:, i]))
        return actions
