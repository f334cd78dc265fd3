"""Behaviour cloning into recurrent (LSTM) policies: sb3-contrib's ``RecurrentPPO`` and the masked variant.

A feed-forward clone (:func:`baselines.rl.imitation.behaviour_clone`) fits each transition on
its own; an LSTM policy must be fitted on *sequences*, each robot's episode in order, so that
its hidden state carries what the observation alone does not show (a scripted controller's
timers and phases, e.g. ``cooperative-push``'s wait for a second pusher). The data are the
same :class:`~baselines.rl.imitation.ExpertData`, whose ``starts`` flag the first transition of
every robot's episode (one robot's transitions are contiguous, in order).

:func:`behaviour_clone_recurrent` cuts every robot-episode into segments of
``sequence_length`` steps and fits minibatches of segments by truncated back-propagation
through time. A segment's initial LSTM state is the state the current network reaches at that
point of its episode (zeros at the episode's start): before every epoch one pass without
gradients runs the actor's and the critic's LSTMs over every episode, segment after segment,
and keeps the state at each segment's start, so the fit sees the states the policy will have
when it runs an episode from its start (as :class:`~baselines.rl.recurrent.AgentMemory` does
in evaluation). The losses are those of the feed-forward clone over the steps of the segments
(padding excluded): the squared error of the Gaussian's mean per dimension divided by the
expert actions' standard deviation (Box), cross-entropy with label smoothing (Discrete; over
the admissible actions for the masked variant, whose observation carries the mask, as in
training; MultiDiscrete: the sum over its parts), and the value head's squared error to the
Monte-Carlo returns weighted by ``vf_coef``. Box ``log_std`` is set afterwards as in the feed-forward clone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

if TYPE_CHECKING:
    from baselines.rl.imitation import ExpertData

__all__ = ["DEFAULT_SEQUENCE_LENGTH", "Segments", "behaviour_clone_recurrent", "segments_of"]

#: Steps per segment of truncated back-propagation through time.
DEFAULT_SEQUENCE_LENGTH = 64


@dataclass
class Segments:
    """The data cut into segments: ``index[s, t]`` is the transition at step ``t`` of segment ``s`` (-1: padding).

    ``episode[s]`` and ``position[s]`` are the segment's robot-episode and its place in it
    (0: the episode's first segment), ``count`` the number of episodes.
    """

    index: np.ndarray
    episode: np.ndarray
    position: np.ndarray
    count: int


def segments_of(starts: np.ndarray, length: int) -> Segments:
    """Cut transitions ``0 .. len(starts)-1`` into robot-episodes (a new one at every ``starts``) and those into segments."""
    if length < 1:
        raise ValueError(f"sequence_length must be >= 1, got {length}")
    n = len(starts)
    if n == 0:
        return Segments(np.zeros((0, length), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), 0)
    first = np.flatnonzero(starts)
    if len(first) == 0 or first[0] != 0:
        first = np.concatenate([[0], first])
    ends = np.concatenate([first[1:], [n]])
    rows, episodes, positions = [], [], []
    for e, (begin, end) in enumerate(zip(first.tolist(), ends.tolist())):
        for p, at in enumerate(range(begin, end, length)):
            row = np.full(length, -1, dtype=np.int64)
            stop = min(at + length, end)
            row[: stop - at] = np.arange(at, stop)
            rows.append(row)
            episodes.append(e)
            positions.append(p)
    return Segments(np.stack(rows), np.array(episodes), np.array(positions), len(first))


def behaviour_clone_recurrent(
    model: Any,
    data: ExpertData,
    epochs: int,
    *,
    batch_size: int = 64,
    learning_rate: float = 1e-3,
    fit_value: bool = True,
    std_fraction: float = 0.2,
    label_smoothing: float = 0.1,
    seed: int = 0,
    sequence_length: int = DEFAULT_SEQUENCE_LENGTH,
) -> dict[str, Any]:
    """Fit ``model.policy`` (an sb3-contrib ``RecurrentActorCriticPolicy``) to ``data``'s sequences in place; the final losses.

    ``batch_size`` is in transitions, as for the feed-forward clone: each minibatch holds
    ``max(1, batch_size // sequence_length)`` segments. Segments are shuffled with a torch
    generator seeded with ``seed``.
    """
    import torch
    import torch.nn.functional as F

    from baselines.rl.imitation import action_parts, labels_admissible, part_logits, parts_cross_entropy

    policy = model.policy
    space = policy.action_space
    mask_width = int(getattr(policy, "mask_width", 0))
    if not isinstance(space, (spaces.Box, spaces.Discrete, spaces.MultiDiscrete)):
        raise ValueError(f"behaviour cloning of a recurrent policy supports Box, Discrete and MultiDiscrete actions, not {space}")
    if epochs < 1:
        raise ValueError(f"epochs must be >= 1, got {epochs}")
    if data.starts is None or len(data.starts) != len(data):
        raise ValueError("recurrent behaviour cloning needs the data's episode starts (ExpertData.starts)")
    box = isinstance(space, spaces.Box)
    device = policy.device
    observations = np.asarray(data.observations, dtype=np.float32)
    masks = None
    if mask_width:  # the masked variant reads each step's mask at the end of its observation
        if data.masks is None:
            masks = np.ones((len(data), mask_width), dtype=bool)
        else:
            masks = np.asarray(data.masks, dtype=bool).reshape(len(data), -1)
        if masks.shape[1] != mask_width:
            raise ValueError(f"data.masks must have {mask_width} columns, got {masks.shape[1]}")
        observations = np.concatenate([observations, masks.astype(np.float32)], axis=1)
    segments = segments_of(np.asarray(data.starts, dtype=bool), sequence_length)
    width = observations.shape[1]
    padded = np.vstack([observations, np.zeros((1, width), np.float32)])  # row -1: padding
    obs = torch.as_tensor(padded, device=device)
    index = torch.as_tensor(segments.index, device=device)
    valid = index >= 0
    flat_index = torch.where(valid, index, torch.full_like(index, len(observations)))
    returns = torch.as_tensor(np.append(data.returns, 0.0).astype(np.float32), device=device)
    if box:
        actions = np.asarray(data.actions, dtype=np.float32).reshape(len(data), -1)
        target_all = torch.as_tensor(np.vstack([actions, np.zeros((1, actions.shape[1]), np.float32)]), device=device)
        half = torch.as_tensor((space.high - space.low) / 2, dtype=torch.float32, device=device).reshape(1, -1)
        real = target_all[:-1]
        scale = torch.maximum(real.std(dim=0, keepdim=True), 1e-3 * half) if len(real) > 1 else half
    else:  # (N + 1, parts) zero-based labels (one column for a Discrete action; row -1: padding)
        labels = np.asarray(data.actions, dtype=np.int64).reshape(len(data), -1) - np.asarray(space.start).reshape(1, -1)
        target_all = torch.as_tensor(np.vstack([labels, np.zeros((1, labels.shape[1]), np.int64)]), device=device)
    allowed_all = None
    if masks is not None:
        allowed_all = torch.as_tensor(np.vstack([masks, np.ones((1, mask_width), bool)]), device=device)
        if not labels_admissible(target_all[:-1], allowed_all[:-1], action_parts(space)):
            raise ValueError("an expert label is an action its own action mask forbids; the data are inconsistent")

    vf_coef = float(getattr(model, "vf_coef", 0.5))
    parameters = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = torch.optim.Adam(parameters, lr=learning_rate)
    generator = torch.Generator().manual_seed(int(seed))
    per_batch = max(1, batch_size // sequence_length)
    n_segments = len(segments.index)
    action_loss = value_loss = math.nan
    policy.set_training_mode(True)
    for _ in range(epochs):
        start_pi, start_vf = _segment_start_states(policy, obs, flat_index, segments)
        order = torch.randperm(n_segments, generator=generator).to(device)
        sums, steps = [0.0, 0.0], 0
        for first in range(0, n_segments, per_batch):
            chosen = order[first : first + per_batch]
            rows = flat_index[chosen].reshape(-1)
            keep = valid[chosen].reshape(-1)
            batch_obs = obs[rows]
            zeros = torch.zeros(len(rows), device=device)
            pi_state = (start_pi[0][:, chosen].contiguous(), start_pi[1][:, chosen].contiguous())
            distribution, _ = policy.get_distribution(batch_obs, pi_state, zeros)
            if box:
                error = ((distribution.distribution.mean - target_all[rows]) / scale) ** 2
                loss_pi = error[keep].mean()
            else:
                logits = [part[keep] for part in part_logits(distribution)]
                given = None if allowed_all is None else allowed_all[rows][keep]
                loss_pi = parts_cross_entropy(logits, target_all[rows][keep], given, label_smoothing)
            loss = loss_pi
            loss_v = torch.zeros(())
            if fit_value:
                vf_state = (start_vf[0][:, chosen].contiguous(), start_vf[1][:, chosen].contiguous())
                values = policy.predict_values(batch_obs, vf_state, zeros).flatten()
                loss_v = F.mse_loss(values[keep], returns[rows][keep])
                loss = loss + vf_coef * loss_v
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            count = int(keep.sum())
            sums[0] += loss_pi.item() * count
            sums[1] += loss_v.item() * count
            steps += count
        action_loss, value_loss = sums[0] / steps, sums[1] / steps
    policy.set_training_mode(False)
    stats: dict[str, Any] = {
        "action_loss": action_loss,
        "value_loss": value_loss if fit_value else math.nan,
        "sequence_length": sequence_length,
    }
    if box and not getattr(policy, "use_sde", False):
        with torch.no_grad():
            start_pi, _ = _segment_start_states(policy, obs, flat_index, segments)
            residuals = []
            for first in range(0, n_segments, 256):
                chosen = torch.arange(first, min(first + 256, n_segments), device=device)
                rows = flat_index[chosen].reshape(-1)
                keep = valid[chosen].reshape(-1)
                state = (start_pi[0][:, chosen].contiguous(), start_pi[1][:, chosen].contiguous())
                distribution, _ = policy.get_distribution(obs[rows], state, torch.zeros(len(rows), device=device))
                residuals.append((distribution.distribution.mean - target_all[rows])[keep])
            residual = torch.cat(residuals)
            spread = residual.std(dim=0) if len(residual) > 1 else torch.zeros_like(half[0])
            std = torch.maximum(std_fraction * half[0], spread)
            policy.log_std.copy_(torch.log(std).reshape(policy.log_std.shape))
        stats["action_std"] = [float(s) for s in std]
    return stats


def _segment_start_states(policy: Any, obs: Any, flat_index: Any, segments: Segments) -> tuple[tuple[Any, Any], tuple[Any, Any]]:
    """The actor's and the critic's LSTM ``(h, c)`` at the start of every segment, shape ``(layers, n_segments, hidden)``.

    Each episode's segments run in order from a zero state (no gradients); a critic without an
    LSTM of its own gets the actor's states (unused by its value head).
    """
    import torch
    from stable_baselines3.common.policies import ActorCriticPolicy

    layers, _, hidden = policy.lstm_hidden_state_shape
    n, device = len(segments.index), obs.device
    networks = [(policy.lstm_actor, policy.pi_features_extractor)]
    if policy.lstm_critic is not None:
        networks.append((policy.lstm_critic, policy.vf_features_extractor))
    starts = []  # per network: (h, c) at every segment's start
    with torch.no_grad():
        for lstm, extractor in networks:
            h0, c0 = (torch.zeros(layers, n, hidden, device=device) for _ in range(2))
            h, c = (torch.zeros(layers, segments.count, hidden, device=device) for _ in range(2))  # per episode, so far
            for position in range(int(segments.position.max()) + 1 if n else 0):
                at = np.flatnonzero(segments.position == position)
                episodes = torch.as_tensor(segments.episode[at], device=device)
                at = torch.as_tensor(at, device=device)
                h0[:, at], c0[:, at] = h[:, episodes], c[:, episodes]
                rows = flat_index[at]  # (segments, steps); padding only in an episode's last segment, whose end state is unused
                features = super(ActorCriticPolicy, policy).extract_features(obs[rows.reshape(-1)], extractor)
                sequence = features.reshape(len(at), -1, lstm.input_size).swapaxes(0, 1)
                _, (h[:, episodes], c[:, episodes]) = lstm(sequence, (h0[:, at].contiguous(), c0[:, at].contiguous()))
            starts.append((h0, c0))
    return starts[0], starts[-1]
