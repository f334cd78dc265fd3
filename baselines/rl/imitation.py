"""Imitation of the scripted baselines: expert actions in ``infos`` and behaviour cloning for PPO.

:class:`ExpertActions` wraps a PettingZoo ``ParallelEnv`` and puts a registered scripted
policy's action for every live agent into ``infos[agent]["expert_action"]`` after every
reset and step, without changing the episode: the env steps with the actions it is given,
and the policy gets copies of the observations and infos and cannot consume the env's
random generators (they are restored after every call). The label is in the action space
the learner uses: ``baselines.train`` passes SB3's actions to the env unscaled
(:class:`~baselines.rl.sb3_env.TeamVecEnv` only clips Box actions), so that space is the
env's; Box actions are clipped into it, Discrete ones made ``int``.

Behaviour cloning (``python -m baselines.train --bc-expert goto``; :func:`pretrain`;
design and measurements in ``docs/training.md``):

1. :func:`collect_expert_data` runs the expert through one env copy (the first episode
   reset with the run's seed, later ones continuing its random stream), executing its
   actions perturbed by ``noise`` but labelling with the clean ones, and keeps the first
   ``steps`` agent transitions: observation, expert action and the agent's discounted
   Monte-Carlo return from there (``gamma`` of the algorithm; whole episodes are played so
   the returns are complete).
2. :func:`behaviour_clone` fits an SB3 ``ActorCriticPolicy`` (PPO, A2C) or sb3-contrib's
   ``MaskableActorCriticPolicy`` (MaskablePPO; cross-entropy of the masked logits) with Adam for
   ``epochs`` passes: Box actions by the squared error of the Gaussian's mean, each
   dimension divided by the expert actions' standard deviation; Discrete ones by
   cross-entropy with label smoothing (no action gets probability 1), MultiDiscrete ones by
   the sum of their parts' (a learned motion ⊕ message action, e.g.: with
   :class:`~baselines.rl.message_actions.FlatMessageActions` below :class:`ExpertActions`, the
   expert's ``Dict`` actions are encoded into the flat action and its masks too); the value head by the
   squared error to the Monte-Carlo returns (weighted by the algorithm's ``vf_coef``), so
   that PPO's first advantages are not those of a random critic. Then Box ``log_std`` is set
   to ``log(max(std_fraction · half range, residual std))``: PPO starts from the expert's
   behaviour with exploration noise of a known size instead of the clone's near-zero
   residual (over-confident) or SB3's initial std of 1 in every unit.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo.utils.env import ParallelEnv
from pettingzoo.utils.wrappers.base_parallel import BaseParallelWrapper

from baselines.episode import success_of
from baselines.policy import Policy
from baselines.registry import make_policy, policies, policy_class, required_config
from baselines.rl.recurrent import AgentMemory, is_recurrent

__all__ = [
    "DEFAULT_BC_EPOCHS",
    "DEFAULT_BC_NOISE",
    "DEFAULT_BC_STEPS",
    "ExpertActions",
    "ExpertData",
    "behaviour_clone",
    "clone_defaults",
    "collect_expert_data",
    "collect_learner_data",
    "learner_action",
    "make_expert",
    "pretrain",
]

DEFAULT_BC_STEPS, DEFAULT_BC_EPOCHS = 20_000, 30
#: Perturbation of the executed expert actions while collecting (see :func:`collect_expert_data`).
DEFAULT_BC_NOISE = 0.5
#: Initial Box action std after cloning, as a fraction of each dimension's half range.
DEFAULT_STD_FRACTION = 0.2


def learner_action(space: spaces.Space, action: Any) -> Any:
    """``action`` as the learner emits it: clipped ``space.dtype`` array (Box), ``int`` (Discrete), else unchanged."""
    if isinstance(space, spaces.Box):
        return np.clip(np.asarray(action, dtype=space.dtype).reshape(space.shape), space.low, space.high)
    if isinstance(space, spaces.Discrete):
        return int(np.asarray(action).reshape(()))
    return action


def make_expert(name: str, env: Any, **policy_kwargs: Any) -> Policy:
    """Scripted policy ``name`` for ``env.unwrapped``: ``KeyError`` if unknown, ``ValueError`` if it does not fit.

    Unlike ``baselines.evaluate``, the env config is not adapted to the expert: the expert
    must act in the learner's action space, so a ``required_config`` it lacks is an error.
    """
    if name not in policies():
        raise KeyError(f"unknown expert {name!r}; choose a registered scripted policy: {', '.join(policies())}")
    policy_class(name).check_env(env.unwrapped, name)  # the env id and observation fields first
    config = getattr(env.unwrapped, "config", None)
    for key, value in required_config(name).items():
        have = getattr(config, key, None)
        if have != value:
            raise ValueError(
                f"expert {name!r} needs the env config {key}={value}, this env has {key}={have} (--set {key}={value})"
            )
    return make_policy(name, env.unwrapped, **policy_kwargs)  # ValueError naming the policy, the env and what is missing


class ExpertActions(BaseParallelWrapper):
    """A ``ParallelEnv`` whose ``infos[agent]["expert_action"]`` is scripted policy ``policy_name``'s action.

    Every agent live after a reset or step gets the action the policy (built with
    ``make_policy(policy_name, env.unwrapped, **policy_kwargs)``) takes on the current
    observations; agents that finished get none. The policy is reset like in
    ``baselines.run_episode``: with the reset's seed, or after an unseeded reset with a seed
    drawn from the wrapper's own generator (seeded by the last seeded reset). Observations,
    rewards and the env's state are those of the unwrapped env for the same actions; the
    wrapper pickles and deep-copies (with the policy's state) when the env and policy do.
    """

    def __init__(self, env: ParallelEnv, policy_name: str, **policy_kwargs: Any) -> None:
        super().__init__(env)
        #: A learner's flat motion ⊕ message action (:class:`~baselines.rl.message_actions.FlatMessageActions`
        #: below this wrapper): labels are encoded with it and ``action_mask`` is the flat action's.
        self.codec = getattr(env, "codec", None)
        self.policy_name = policy_name
        self.policy = make_expert(policy_name, env, **policy_kwargs)
        self.policy_seeds = np.random.default_rng()

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        observations, infos = self.env.reset(seed=seed, options=options)
        if seed is not None:
            self.policy_seeds = np.random.default_rng(seed)
        with _rngs_kept(self.env):
            self.policy.reset(seed if seed is not None else int(self.policy_seeds.integers(2**31)))
        return observations, self._label(observations, infos)

    def step(self, actions: dict) -> tuple[dict, dict, dict, dict, dict]:
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        return observations, rewards, terminations, truncations, self._label(observations, infos)

    def expert_actions(self, observations: Mapping[str, Any], infos: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
        """The policy's actions for the live agents in ``observations`` (the env's random state is left as it was)."""
        live = [a for a in self.env.agents if a in observations]
        if not live:
            return {}
        seen = copy.deepcopy({a: observations[a] for a in live})
        with _rngs_kept(self.env):
            actions = self.policy.act(seen, {a: dict(info) for a, info in infos.items()})
        if self.codec is not None:
            return {a: self.codec.encode(actions[a]) for a in live}
        return {a: learner_action(self.env.action_space(a), actions[a]) for a in live}

    def _label(self, observations: dict, infos: dict) -> dict[str, dict[str, Any]]:
        expert = self.expert_actions(observations, infos)
        labelled = {agent: dict(info) for agent, info in infos.items()}
        for agent, action in expert.items():
            labelled.setdefault(agent, {})["expert_action"] = action
        if self.codec is not None:
            key = self.codec.motion_key
            for info in labelled.values():
                mask = info.get("action_mask")
                if isinstance(mask, Mapping):
                    info["action_mask"] = self.codec.mask(mask.get(key))
        return labelled


@contextmanager
def _rngs_kept(env: ParallelEnv) -> Iterator[None]:
    """Restore the env's random generators on exit: ``np_random`` and those of its action spaces (and their parts)."""
    saved: list[tuple[Any, str, Any, Any]] = []

    def keep(owner: Any, attribute: str) -> None:
        generator = getattr(owner, attribute, None)
        state = generator.bit_generator.state if isinstance(generator, np.random.Generator) else None
        saved.append((owner, attribute, generator, state))

    def keep_space(space: spaces.Space) -> None:
        keep(space, "_np_random")
        parts = getattr(space, "spaces", None)
        for part in parts.values() if isinstance(parts, Mapping) else parts or ():
            keep_space(part)

    base = env.unwrapped
    keep(base, "np_random")
    for agent in base.possible_agents:
        keep_space(base.action_space(agent))
    try:
        yield
    finally:
        for owner, attribute, generator, state in saved:
            if getattr(owner, attribute, None) is not generator:
                setattr(owner, attribute, generator)
            if state is not None:
                generator.bit_generator.state = state


@dataclass
class ExpertData:
    """Agent transitions of expert episodes: observations, expert actions and discounted returns to go."""

    observations: np.ndarray
    actions: np.ndarray
    returns: np.ndarray
    episodes: int
    success_rate: float
    mean_return: float
    #: The action mask (bool, one row per transition) the env gave at each observation; None without masks.
    masks: np.ndarray | None = None
    #: True at the first transition of each robot's episode (a robot's transitions are contiguous, in
    #: order): the sequences a recurrent clone fits (:mod:`baselines.rl.recurrent_imitation`).
    starts: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.observations)

    def merged(self, other: ExpertData) -> ExpertData:
        """Both data sets in one (DAgger's aggregation); episode counts add, rates are ``other``'s."""
        return ExpertData(
            observations=np.concatenate([self.observations, other.observations]),
            actions=np.concatenate([self.actions, other.actions]),
            returns=np.concatenate([self.returns, other.returns]),
            episodes=self.episodes + other.episodes,
            success_rate=other.success_rate,
            mean_return=other.mean_return,
            masks=None if self.masks is None or other.masks is None else np.concatenate([self.masks, other.masks]),
            starts=None if self.starts is None or other.starts is None else np.concatenate([self.starts, other.starts]),
        )


def collect_expert_data(
    env: ParallelEnv,
    expert: str,
    steps: int,
    seed: int,
    gamma: float = 0.99,
    noise: float = 0.0,
    **policy_kwargs: Any,
) -> ExpertData:
    """The first ``steps`` agent transitions of expert ``expert`` on ``env`` (whole episodes are played).

    The first episode is reset with ``seed``, later ones continue the env's random stream.
    ``noise > 0`` executes perturbed actions (Box: Gaussian with std ``noise`` · half range;
    Discrete: a random action with probability ``noise``, an admissible one where the env
    gives action masks; MultiDiscrete: so each part; from a generator seeded with ``seed``) while the labels stay the
    expert's, so the data cover states next to the expert's path. ``returns`` are each agent's
    discounted rewards from that step on.
    """
    rng = np.random.default_rng(seed)
    wrapped = ExpertActions(env, expert, **policy_kwargs)

    def perturbed(
        observations: Mapping[str, Any], labels: Mapping[str, Any], masks: Mapping[str, np.ndarray | None]
    ) -> dict[str, Any]:
        return {a: _perturb(wrapped.action_space(a), label, noise, rng, masks.get(a)) for a, label in labels.items()}

    return _labelled_rollouts(wrapped, steps, seed, gamma, perturbed)


def collect_learner_data(
    env: ParallelEnv,
    model: Any,
    expert: str,
    steps: int,
    seed: int,
    gamma: float = 0.99,
    **policy_kwargs: Any,
) -> ExpertData:
    """``steps`` agent transitions in which ``model`` (deterministic) drives and expert ``expert`` labels (DAgger's data).

    As :func:`collect_expert_data`, but the executed actions are the learner's, so the data
    cover the states the learner reaches, with the expert's action in each as the label. A
    maskable model (sb3-contrib's ``MaskablePPO``) gets the env's action masks, as in training.
    """
    wrapped = ExpertActions(env, expert, **policy_kwargs)
    maskable = _is_maskable(model.policy)
    memory = AgentMemory(model) if is_recurrent(model) else None  # each robot's LSTM state through its episode

    def learner(
        observations: Mapping[str, Any], labels: Mapping[str, Any], masks: Mapping[str, np.ndarray | None]
    ) -> dict[str, Any]:
        live = list(labels)
        batch = np.stack([observations[a] for a in live])
        allowed = np.stack([masks[a] for a in live]) if all(masks.get(a) is not None for a in live) else None
        if memory is not None:
            actions = memory.predict(live, batch, deterministic=True, masks=allowed)
        elif maskable and allowed is not None:
            actions, _ = model.predict(batch, deterministic=True, action_masks=allowed)
        else:
            actions, _ = model.predict(batch, deterministic=True)
        return {a: learner_action(wrapped.action_space(a), action) for a, action in zip(live, actions)}

    return _labelled_rollouts(wrapped, steps, seed, gamma, learner, on_reset=None if memory is None else memory.reset)


def _labelled_rollouts(
    wrapped: ExpertActions,
    steps: int,
    seed: int,
    gamma: float,
    choose: Callable[[Mapping[str, Any], Mapping[str, Any], Mapping[str, np.ndarray | None]], dict[str, Any]],
    on_reset: Callable[[], None] | None = None,
) -> ExpertData:
    """Whole episodes until ``steps`` agent transitions: ``choose(observations, labels, masks)`` acts, the expert labels.

    ``masks`` are the agents' ``infos[agent]["action_mask"]`` (None where the env gives none);
    they are kept per transition when every transition has one. ``on_reset`` is called at
    every episode start (a recurrent learner forgets its robots' states).
    """
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    observations: list[np.ndarray] = []
    actions: list[Any] = []
    returns: list[float] = []
    masks: list[np.ndarray | None] = []
    starts: list[bool] = []
    episodes = successes = 0
    totals: list[float] = []
    while len(observations) < steps:
        obs, infos = wrapped.reset(seed=seed if episodes == 0 else None)
        if on_reset is not None:
            on_reset()
        tracks: dict[str, list[tuple[np.ndarray, Any, float, np.ndarray | None]]] = {}
        done_infos = infos
        while wrapped.agents:
            live = list(wrapped.agents)
            labels = {a: infos[a]["expert_action"] for a in live}
            allowed = {a: _mask_of(infos[a]) for a in live}
            executed = choose(obs, labels, allowed)
            next_obs, rewards, _, _, infos = wrapped.step(executed)
            for a in live:
                observation = np.asarray(obs[a], dtype=np.float32)
                tracks.setdefault(a, []).append((observation, labels[a], float(rewards.get(a, 0.0)), allowed[a]))
            obs, done_infos = next_obs, infos
        episodes += 1
        successes += success_of(done_infos)
        for track in tracks.values():
            totals.append(sum(r for _, _, r, _ in track))
            to_go = 0.0
            tail = []
            for _, _, reward, _ in reversed(track):
                to_go = reward + gamma * to_go
                tail.append(to_go)
            for t, ((o, a, _, m), g) in enumerate(zip(track, reversed(tail))):
                observations.append(o)
                actions.append(a)
                returns.append(g)
                masks.append(m)
                starts.append(t == 0)
    kept = masks[:steps]
    return ExpertData(
        observations=np.stack(observations[:steps]),
        actions=np.stack([np.asarray(a) for a in actions[:steps]]),
        returns=np.asarray(returns[:steps], dtype=np.float32),
        episodes=episodes,
        success_rate=successes / episodes,
        mean_return=float(np.mean(totals)),
        masks=np.stack(kept) if all(m is not None for m in kept) else None,
        starts=np.asarray(starts[:steps], dtype=bool),
    )


def _mask_of(info: Mapping[str, Any]) -> np.ndarray | None:
    """The agent's ``action_mask`` from its info as a flat bool array, or None."""
    mask = info.get("action_mask")
    return None if mask is None else np.asarray(mask, dtype=bool).reshape(-1)


def _is_maskable(policy: Any) -> bool:
    """Whether ``policy`` is sb3-contrib's ``MaskableActorCriticPolicy`` (imported only if sb3-contrib is installed)."""
    try:
        from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
    except ImportError:
        return False
    return isinstance(policy, MaskableActorCriticPolicy)


def _perturb(space: spaces.Space, action: Any, noise: float, rng: np.random.Generator, mask: np.ndarray | None = None) -> Any:
    if noise <= 0:
        return action
    if isinstance(space, spaces.Box):
        half = (space.high - space.low) / 2
        return learner_action(space, action + rng.normal(0.0, noise, size=space.shape) * half)
    if isinstance(space, spaces.Discrete) and rng.random() < noise:
        if mask is not None and mask.any():  # a random admissible action: a masked one would be refused
            return int(space.start + rng.choice(np.flatnonzero(mask)))
        return int(space.start + rng.integers(space.n))
    if isinstance(space, spaces.MultiDiscrete):  # each part on its own: a random admissible value with probability noise
        out = np.array(action, dtype=np.int64).reshape(-1)
        parts = action_parts(space)
        masks = np.split(mask, np.cumsum(parts)[:-1]) if mask is not None else [None] * len(parts)
        for j, (n, allowed) in enumerate(zip(parts, masks)):
            if rng.random() < noise:
                choices = np.flatnonzero(allowed) if allowed is not None and allowed.any() else np.arange(n)
                out[j] = int(rng.choice(choices))
        return (out + np.asarray(space.start).reshape(-1)).reshape(np.shape(action))
    return action


def behaviour_clone(
    model: Any,
    data: ExpertData,
    epochs: int = DEFAULT_BC_EPOCHS,
    *,
    batch_size: int = 64,
    learning_rate: float = 1e-3,
    fit_value: bool = True,
    std_fraction: float = DEFAULT_STD_FRACTION,
    label_smoothing: float = 0.1,
    seed: int = 0,
) -> dict[str, Any]:
    """Fit ``model.policy`` (an SB3 ``ActorCriticPolicy``) to ``data`` in place; returns the final losses.

    A recurrent policy (sb3-contrib's ``RecurrentPPO``, or the masked variant) is fitted on the
    data's robot-episodes as sequences (:func:`baselines.rl.recurrent_imitation.behaviour_clone_recurrent`).

    See the module docstring for the losses and the Box ``log_std`` set afterwards (left
    alone with gSDE, ``use_sde=True``, whose noise has another parametrisation). Minibatches
    are shuffled with a torch generator seeded with ``seed`` (no global state).
    """
    if is_recurrent(model):  # sequences, not single transitions
        from baselines.rl.recurrent_imitation import behaviour_clone_recurrent

        return behaviour_clone_recurrent(
            model,
            data,
            epochs,
            batch_size=batch_size,
            learning_rate=learning_rate,
            fit_value=fit_value,
            std_fraction=std_fraction,
            label_smoothing=label_smoothing,
            seed=seed,
        )
    import torch
    import torch.nn.functional as F
    from stable_baselines3.common.policies import ActorCriticPolicy

    policy = model.policy
    maskable = _is_maskable(policy)
    if not isinstance(policy, ActorCriticPolicy) and not maskable:
        raise ValueError(f"behaviour cloning needs an actor-critic policy (PPO, A2C, MaskablePPO), not {type(policy).__name__}")
    space = policy.action_space
    discrete = (spaces.Discrete, spaces.MultiDiscrete)
    if not isinstance(space, (spaces.Box, *discrete)) or (maskable and not isinstance(space, discrete)):
        kinds = "Discrete and MultiDiscrete" if maskable else "Box, Discrete and MultiDiscrete"
        raise ValueError(f"behaviour cloning of a {type(policy).__name__} supports {kinds} actions, not {space}")
    if epochs < 1:
        raise ValueError(f"epochs must be >= 1, got {epochs}")
    parts = action_parts(space)
    masks = data.masks if maskable else None
    if masks is not None and masks.shape != (len(data), sum(parts)):
        raise ValueError(f"data.masks must have shape {(len(data), sum(parts))}, got {masks.shape}")
    device = policy.device
    obs = torch.as_tensor(data.observations, dtype=torch.float32, device=device)
    returns = torch.as_tensor(data.returns, dtype=torch.float32, device=device)
    box = isinstance(space, spaces.Box)
    if box:
        target = torch.as_tensor(data.actions, dtype=torch.float32, device=device).reshape(len(obs), -1)
        half = torch.as_tensor((space.high - space.low) / 2, dtype=torch.float32, device=device).reshape(1, -1)
        scale = torch.maximum(target.std(dim=0, keepdim=True), 1e-3 * half) if len(obs) > 1 else half
    else:  # (N, parts) zero-based labels, one column for a Discrete action
        start = torch.as_tensor(np.asarray(space.start).reshape(1, -1), dtype=torch.long, device=device)
        target = torch.as_tensor(data.actions, dtype=torch.long, device=device).reshape(len(obs), -1) - start
    allowed = None if masks is None else torch.as_tensor(masks, dtype=torch.bool, device=device)
    if allowed is not None and not labels_admissible(target, allowed, parts):
        raise ValueError("an expert label is an action its own action mask forbids; the data are inconsistent")
    vf_coef = float(getattr(model, "vf_coef", 0.5))
    parameters = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = torch.optim.Adam(parameters, lr=learning_rate)
    generator = torch.Generator().manual_seed(int(seed))
    policy.set_training_mode(True)
    action_loss = value_loss = math.nan
    for _ in range(epochs):
        order = torch.randperm(len(obs), generator=generator).to(device)
        sums = [0.0, 0.0]
        for start in range(0, len(obs), batch_size):
            index = order[start : start + batch_size]
            if box:
                loss_pi = (((policy.get_distribution(obs[index]).distribution.mean - target[index]) / scale) ** 2).mean()
            else:
                given = {} if allowed is None else {"action_masks": allowed[index]}
                logits = part_logits(policy.get_distribution(obs[index], **given))
                loss_pi = parts_cross_entropy(logits, target[index], None if allowed is None else allowed[index], label_smoothing)
            loss = loss_pi
            loss_v = torch.zeros(())
            if fit_value:
                loss_v = F.mse_loss(policy.predict_values(obs[index]).flatten(), returns[index])
                loss = loss + vf_coef * loss_v
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            sums[0] += loss_pi.item() * len(index)
            sums[1] += loss_v.item() * len(index)
        action_loss, value_loss = sums[0] / len(obs), sums[1] / len(obs)
    policy.set_training_mode(False)
    stats = {"action_loss": action_loss, "value_loss": value_loss if fit_value else math.nan}
    if box and not getattr(policy, "use_sde", False):
        with torch.no_grad():
            mean = torch.cat([policy.get_distribution(obs[i : i + 4096]).distribution.mean for i in range(0, len(obs), 4096)])
            residual = (mean - target).std(dim=0) if len(obs) > 1 else torch.zeros_like(half[0])
            std = torch.maximum(std_fraction * half[0], residual)
            policy.log_std.copy_(torch.log(std).reshape(policy.log_std.shape))
        stats["action_std"] = [float(s) for s in std]
    return stats


def _masked_cross_entropy(log_p: Any, target: Any, allowed: Any, label_smoothing: float) -> Any:
    """Mean cross-entropy of masked log-probabilities to labels smoothed over the admissible actions only.

    The target puts ``1 − ε`` on the label and ``ε / |A(x)|`` on each admissible action (ε =
    ``label_smoothing``); masked actions get 0 (their log-probability, about −1e8, would
    otherwise dominate the loss). With every action admissible this is PyTorch's
    ``cross_entropy(..., label_smoothing=ε)``.
    """
    import torch

    admissible = allowed.float()
    smooth = admissible * (label_smoothing / admissible.sum(dim=1, keepdim=True))
    one_hot = torch.nn.functional.one_hot(target, log_p.shape[1]).float()
    weights = (1.0 - label_smoothing) * one_hot + smooth
    return -(weights * torch.where(allowed, log_p, torch.zeros_like(log_p))).sum(dim=1).mean()


def action_parts(space: spaces.Space) -> list[int]:
    """The sizes of a discrete action's parts (``[n]`` for ``Discrete``, ``nvec`` for ``MultiDiscrete``; [] otherwise)."""
    if isinstance(space, spaces.Discrete):
        return [int(space.n)]
    if isinstance(space, spaces.MultiDiscrete):
        return [int(n) for n in np.asarray(space.nvec).ravel()]
    return []


def labels_admissible(target: Any, allowed: Any, parts: list[int]) -> bool:
    """Whether every label (``(N,)`` or ``(N, parts)``, zero-based) is admissible under its mask (MaskablePPO's layout)."""
    import torch

    labels = target.reshape(len(target), -1)
    offsets = torch.as_tensor(np.concatenate([[0], np.cumsum(parts)[:-1]]), dtype=torch.long, device=labels.device)
    rows = torch.arange(len(labels), device=labels.device).reshape(-1, 1)
    return bool(allowed[rows, labels + offsets.reshape(1, -1)].all())


def part_logits(distribution: Any) -> list[Any]:
    """The logits of each part of an SB3 (or sb3-contrib) categorical distribution, masked ones as the policy set them."""
    parts = getattr(distribution, "distributions", None)  # sb3-contrib's masked multi-categorical
    if parts is None:
        parts = distribution.distribution
    return [part.logits for part in (parts if isinstance(parts, (list, tuple)) else [parts])]


def parts_cross_entropy(logits: list[Any], target: Any, allowed: Any | None, label_smoothing: float) -> Any:
    """The sum over the action's parts of each part's (masked) cross-entropy, smoothed as :func:`_masked_cross_entropy`."""
    import torch
    import torch.nn.functional as F

    widths = [int(part.shape[1]) for part in logits]
    masks = [None] * len(logits) if allowed is None else torch.split(allowed, widths, dim=1)
    total = torch.zeros((), device=target.device)
    for j, (logit, mask) in enumerate(zip(logits, masks)):
        if mask is None:
            total = total + F.cross_entropy(logit, target[:, j], label_smoothing=label_smoothing)
        else:
            total = total + _masked_cross_entropy(logit, target[:, j], mask, label_smoothing)
    return total


def clone_defaults() -> dict[str, Any]:
    """:func:`behaviour_clone`'s settings and their defaults (``batch_size``, ``learning_rate``, ``fit_value``, ...)."""
    import inspect

    parameters = inspect.signature(behaviour_clone).parameters.values()
    return {p.name: p.default for p in parameters if p.kind is p.KEYWORD_ONLY and p.name != "seed"}


def pretrain(
    model: Any,
    make_env: Callable[[], ParallelEnv],
    expert: str,
    steps: int = DEFAULT_BC_STEPS,
    epochs: int = DEFAULT_BC_EPOCHS,
    seed: int = 0,
    noise: float = DEFAULT_BC_NOISE,
    dagger_rounds: int = 0,
    dagger_steps: int | None = None,
    dagger_epochs: int | None = None,
    expert_kwargs: Mapping[str, Any] | None = None,
    **options: Any,
) -> dict[str, Any]:
    """Collect ``steps`` expert transitions on ``make_env()`` and clone them into ``model``; returns a sidecar record.

    ``noise`` goes to :func:`collect_expert_data`, ``options`` to :func:`behaviour_clone`;
    ``expert_kwargs`` are the expert's constructor arguments (``make_policy(expert, env,
    **expert_kwargs)``) for the expert data and the DAgger labels alike, e.g.
    ``{"look_cycles": 0}`` for an ``sbs`` teacher that never stops to look.
    Then ``dagger_rounds`` rounds of DAgger (Ross, Gordon and Bagnell 2011): the clone drives
    ``dagger_steps`` transitions (default ``steps``) labelled by the expert
    (:func:`collect_learner_data`, round ``k`` reset with ``seed + 1 + k``), which join the
    data, and the clone is refitted on all of it for ``dagger_epochs`` passes (default
    ``epochs``), continuing from its weights. The record holds the expert's success rate
    and mean return on the collected episodes, the clone's success rate in each DAgger
    round, the final losses and the wall time; the model's timestep counter is not changed.
    """
    if dagger_rounds < 0:
        raise ValueError(f"dagger_rounds must be >= 0, got {dagger_rounds}")
    started = time.time()
    gamma = float(getattr(model, "gamma", 0.99))
    teacher = dict(expert_kwargs or {})
    env = make_env()
    try:
        data = collect_expert_data(env, expert, steps, seed, gamma=gamma, noise=noise, **teacher)
        expert_record = {
            "expert_episodes": data.episodes,
            "expert_success_rate": data.success_rate,
            "expert_mean_return": data.mean_return,
        }
        stats = behaviour_clone(model, data, epochs, seed=seed, **options)
        learner_success = []
        for k in range(dagger_rounds):
            fresh = collect_learner_data(env, model, expert, dagger_steps or steps, seed + 1 + k, gamma=gamma, **teacher)
            learner_success.append(fresh.success_rate)
            data = data.merged(fresh)
            stats = behaviour_clone(model, data, dagger_epochs or epochs, seed=seed + 1 + k, **options)
    finally:
        env.close()
    clone = {**clone_defaults(), **options}  # every cloning setting as used, so the sidecar tells them all
    record = {**expert_record, "noise": noise, **clone, **stats, "wall_time_s": round(time.time() - started, 3)}
    if teacher:
        record["expert_kwargs"] = teacher
    if dagger_rounds:
        record.update(dagger_rounds=dagger_rounds, dagger_transitions=len(data), dagger_learner_success=learner_success)
    return record
