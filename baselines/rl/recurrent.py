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

Action masks: sb3-contrib has no masked ``RecurrentPPO``; masked action types (Exploration's
``operator``, Rendezvous' ``next_place``, ...) are refused with one line
(:func:`masks_refusal`) rather than trained into a policy that picks masked actions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["RECURRENT_ALGORITHMS", "AgentMemory", "is_recurrent", "masks_refusal"]

#: Algorithms whose policy has a hidden state (``model.predict`` takes ``state`` and ``episode_start``).
RECURRENT_ALGORITHMS = frozenset({"recurrent_ppo"})
#: The saved policy class's module of a ``RecurrentPPO`` model (how a zip without sidecar is recognised).
RECURRENT_POLICY_MODULE = "sb3_contrib.common.recurrent.policies"


def is_recurrent(model: Any) -> bool:
    """Whether ``model``'s policy is recurrent (it has ``lstm_hidden_state_shape``, as sb3-contrib's LSTM policies)."""
    return getattr(getattr(model, "policy", None), "lstm_hidden_state_shape", None) is not None


def masks_refusal(algo: str, env_name: str, action_type: str) -> str:
    """The one-line reason a recurrent ``algo`` cannot train on a masked action type, and what to use instead."""
    return (
        f"{algo} cannot respect the action masks of {env_name} (action_type={action_type!r}): sb3-contrib has no masked "
        "RecurrentPPO, and unmasked it would pick actions the env refuses; use --algo maskable-ppo (masks, no memory) "
        "or an action type without masks for recurrent-ppo"
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

    def reset(self) -> None:
        """Forget every robot's state: the next step of each is an episode start."""
        self.states.clear()

    def predict(self, agents: list[str], observations: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """Actions of ``agents`` (rows of ``observations``), carrying each one's hidden state to its next call."""
        starts = np.array([agent not in self.states for agent in agents], dtype=bool)
        h = np.stack([self.states.get(a, (self._zero, self._zero))[0] for a in agents], axis=1)
        c = np.stack([self.states.get(a, (self._zero, self._zero))[1] for a in agents], axis=1)
        actions, (h, c) = self.model.predict(observations, state=(h, c), episode_start=starts, deterministic=deterministic)
        for i, agent in enumerate(agents):
            self.states[agent] = (np.array(h[:, i]), np.array(c[:, i]))
        return actions
