"""Learned messages for SB3: a motion ⊕ message ``Dict`` action as one flat action PPO and MaskablePPO accept.

With ``comm_dim > 0`` every teamgym env's action is ``Dict(motion=..., message=Box(-1, 1,
(comm_dim,)))`` (:class:`teamgym.envs.actions.WithMessage`), and with Rendezvous'
``protocol_messages=True`` it is ``Dict(move=..., message=Box(-1, 2³¹−1, (message_len,), int32))``
(the protocol's integer records). Stable-Baselines3 learns neither ``Dict`` action. A
:class:`MessageCodec` turns such a space into one flat space whose kind follows the motion's:

* continuous motion (``Box``): ``Box`` = motion's bounds ⊕ message. A learned message keeps
  its ``[-1, 1]`` bounds; protocol tokens are ``[-1, 1]`` each, token ``i`` of value ``x``
  written as ``round((x + 1)/2 · (V − 1)) − 1``;
* discrete motion (``Discrete(n)`` or ``MultiDiscrete``): ``MultiDiscrete`` = motion's
  values ⊕ one value per message entry. A learned message entry has ``levels`` values
  ``-1 + 2k/(levels − 1)``; a protocol token has ``vocab`` values ``k − 1`` (0 is the padding −1).

A protocol message is the first ``tokens`` values of the env's ``message_len`` vector, the
rest padding (−1): the learner writes records ``[kind, n, v_1 … v_n]`` itself, and the env
transmits only well-formed ones (:func:`teamgym.envs.rendezvous.messages.used_length`), 4
bytes a value, as it does for the scripted protocol. Action masks are kept: the mask of the
motion part is the env's, every message value is admissible (MaskablePPO's ``MultiDiscrete``
mask is the concatenation of the parts').

:class:`FlatMessageActions` wraps a ``ParallelEnv`` with the flat space for training
(:class:`~baselines.rl.sb3_env.TeamVecEnv` steps it through the PettingZoo API); the env
itself is unchanged, so the messages go through its channel with its range, loss (throughput),
latency and byte budget. ``baselines.evaluate`` decodes a saved model's flat actions with
the same codec (:class:`~baselines.rl.sb3_policy.SB3Policy`; the settings are the sidecar's
``message_actions``). ``decode(encode(a)) == a`` for every action on the codec's grid.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo.utils.env import ParallelEnv
from pettingzoo.utils.wrappers.base_parallel import BaseParallelWrapper

__all__ = [
    "DEFAULT_LEVELS",
    "DEFAULT_TOKENS",
    "DEFAULT_VOCAB",
    "FlatMessageActions",
    "MessageCodec",
    "MessageSettings",
    "is_message_space",
]

#: Values of one learned-message entry when the motion is discrete (-1, -0.5, 0, 0.5, 1).
DEFAULT_LEVELS = 5
#: Protocol-message values the learner writes (at most the env's ``message_len``).
DEFAULT_TOKENS = 8
#: Values of one protocol token: -1 (padding) .. 62 (kinds 1–5, counts, place indices of maps up to 63 places).
DEFAULT_VOCAB = 64


@dataclass(frozen=True)
class MessageSettings:
    """How a motion ⊕ message action is flattened (the sidecar's ``message_actions``); ``None``: the default."""

    levels: int | None = None
    tokens: int | None = None
    vocab: int | None = None

    def check(self) -> MessageSettings:
        """``self``, or one-line ``ValueError`` naming the setting out of range."""
        for name, least in (("levels", 2), ("tokens", 1), ("vocab", 2)):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, int) or isinstance(value, bool) or value < least):
                raise ValueError(f"message {name} must be an integer >= {least}, got {value!r}")
        return self

    def given(self) -> dict[str, int]:
        """The settings given (``None`` left out)."""
        return {k: v for k, v in asdict(self).items() if v is not None}

    @classmethod
    def from_record(cls, record: Any) -> MessageSettings:
        """The settings of a sidecar's ``message_actions`` (``ValueError`` for anything but an object of those keys)."""
        if not isinstance(record, Mapping) or not set(record) <= {"levels", "tokens", "vocab", "motion_key", "kind"}:
            raise ValueError(f"message_actions must be an object with levels, tokens, vocab; got {record!r}")
        return cls(**{k: record[k] for k in ("levels", "tokens", "vocab") if record.get(k) is not None}).check()


def _motion_key(space: spaces.Space) -> str | None:
    """The motion key of a motion ⊕ message ``Dict`` space, or ``None`` for any other space."""
    if not isinstance(space, spaces.Dict) or len(space.spaces) != 2 or "message" not in space.spaces:
        return None
    (key,) = [k for k in space.spaces if k != "message"]
    return key


def is_message_space(space: spaces.Space) -> bool:
    """Whether ``space`` is a motion ⊕ message ``Dict`` (``comm_dim``, ``protocol_messages``)."""
    return _motion_key(space) is not None


class MessageCodec:
    """Flattens one motion ⊕ message ``Dict`` space (see the module docstring).

    :attr:`space` is the flat space; :meth:`decode` and :meth:`encode` map actions between
    the two, :meth:`mask` the env's motion mask to the flat action's.
    """

    def __init__(self, space: spaces.Space, settings: MessageSettings | None = None) -> None:
        key = _motion_key(space)
        if key is None:
            raise ValueError(f"expected a Dict(motion, message) action space, got {space}")
        settings = (settings or MessageSettings()).check()
        self.dict_space, self.motion_key = space, key
        self.motion, message = space[key], space["message"]
        if not isinstance(message, spaces.Box) or len(message.shape) != 1:
            raise ValueError(f"the message part must be a 1-D Box, got {message}")
        self.message = message
        self.protocol = np.issubdtype(message.dtype, np.integer)
        length = int(message.shape[0])
        if self.protocol:
            self.tokens = settings.tokens if settings.tokens is not None else min(DEFAULT_TOKENS, length)
            if self.tokens > length:
                raise ValueError(f"message tokens={self.tokens} is more than the env's message length {length}")
            self.vocab = settings.vocab if settings.vocab is not None else DEFAULT_VOCAB
            self.levels = None
            if self.vocab - 2 > int(message.high[0]):
                raise ValueError(f"message vocab={self.vocab} writes values above the message's bound {int(message.high[0])}")
            width, values = self.tokens, self.vocab
        else:
            if settings.tokens is not None or settings.vocab is not None:
                raise ValueError("message tokens and vocab apply to protocol messages (integer records), not to comm_dim")
            self.tokens, self.vocab = None, None
            self.levels = settings.levels if settings.levels is not None else DEFAULT_LEVELS
            width, values = length, self.levels
        self.width = int(width)
        if isinstance(self.motion, spaces.Box):
            if len(self.motion.shape) != 1:
                raise ValueError(f"a Box motion must be 1-D to be flattened, got {self.motion}")
            self.discrete = False
            self.motion_size = int(self.motion.shape[0])
            low = message.low if not self.protocol else np.full(width, -1.0)
            high = message.high if not self.protocol else np.full(width, 1.0)
            self.space: spaces.Space = spaces.Box(
                np.concatenate([self.motion.low, low]).astype(np.float32),
                np.concatenate([self.motion.high, high]).astype(np.float32),
                dtype=np.float32,
            )
        elif isinstance(self.motion, (spaces.Discrete, spaces.MultiDiscrete)):
            self.discrete = True
            nvec = (
                [int(self.motion.n)] if isinstance(self.motion, spaces.Discrete) else [int(n) for n in self.motion.nvec.ravel()]
            )
            self.motion_size = len(nvec)
            self.motion_width = int(sum(nvec))
            self.space = spaces.MultiDiscrete(nvec + [int(values)] * width)
        else:
            raise ValueError(f"the motion part must be Box, Discrete or MultiDiscrete to be flattened, got {self.motion}")

    # -- settings ------------------------------------------------------------------------
    def record(self) -> dict[str, Any]:
        """The sidecar's ``message_actions``: the resolved settings and what they flatten."""
        kind = "protocol" if self.protocol else "learned"
        return {"kind": kind, "motion_key": self.motion_key, "levels": self.levels, "tokens": self.tokens, "vocab": self.vocab}

    # -- actions ---------------------------------------------------------------------------
    def _message_values(self, part: np.ndarray) -> np.ndarray:
        """The env's message for the flat action's message part."""
        if self.protocol:
            if self.discrete:
                index = np.clip(np.rint(part), 0, self.vocab - 1)
            else:
                index = np.rint((np.clip(part, -1.0, 1.0) + 1.0) / 2.0 * (self.vocab - 1))
            out = np.full(self.message.shape, -1, dtype=self.message.dtype)
            out[: self.tokens] = index.astype(np.int64) - 1
            return out
        if self.discrete:
            level = np.clip(np.rint(part), 0, self.levels - 1)
            return (-1.0 + 2.0 * level / (self.levels - 1)).astype(self.message.dtype)
        return np.clip(part, self.message.low, self.message.high).astype(self.message.dtype)

    def decode(self, action: Any) -> dict[str, Any]:
        """The env's ``Dict`` action for one flat action (Box parts clipped, discrete parts as ints)."""
        flat = np.asarray(action).reshape(-1)
        head, tail = flat[: self.motion_size], flat[self.motion_size :]
        if self.discrete:
            if isinstance(self.motion, spaces.Discrete):
                motion: Any = int(head[0]) + int(self.motion.start)
            else:
                motion = np.asarray(head, dtype=self.motion.dtype).reshape(self.motion.shape) + self.motion.start
        else:
            motion = np.clip(head.astype(self.motion.dtype), self.motion.low, self.motion.high)
        return {self.motion_key: motion, "message": self._message_values(tail.astype(np.float64))}

    def encode(self, action: Mapping[str, Any]) -> np.ndarray:
        """The flat action for a ``Dict`` action (the nearest on the grid for a message off it; inverse of :meth:`decode`)."""
        motion, message = action[self.motion_key], np.asarray(action["message"], dtype=np.float64).reshape(-1)
        if self.protocol:
            index = np.clip(message[: self.tokens] + 1, 0, self.vocab - 1)
            tail = index if self.discrete else index / (self.vocab - 1) * 2.0 - 1.0
        elif self.discrete:
            tail = np.clip(np.rint((message + 1.0) / 2.0 * (self.levels - 1)), 0, self.levels - 1)
        else:
            tail = message
        if self.discrete:
            head = np.asarray(motion, dtype=np.int64).reshape(-1) - np.asarray(self.motion.start).reshape(-1)
            return np.concatenate([head, np.rint(tail)]).astype(np.int64)
        return np.concatenate([np.asarray(motion, dtype=np.float64).reshape(-1), tail]).astype(np.float32)

    def mask(self, motion_mask: np.ndarray | None) -> np.ndarray | None:
        """The flat action's mask (MaskablePPO's concatenation) for the env's mask of the motion part; ``None`` stays ``None``."""
        if motion_mask is None or not self.discrete:
            return None
        extra = int(np.sum(self.space.nvec)) - self.motion_width
        return np.concatenate([np.asarray(motion_mask).reshape(-1).astype(np.int8), np.ones(extra, dtype=np.int8)])


class FlatMessageActions(BaseParallelWrapper):
    """A ``ParallelEnv`` whose motion ⊕ message actions are :class:`MessageCodec`'s flat ones (decoded before ``env.step``).

    Observations, rewards, infos and the channel are the env's; :meth:`action_masks` gives the
    flat actions' masks (the env's motion masks with every message value admissible).
    """

    def __init__(self, env: ParallelEnv, settings: MessageSettings | None = None) -> None:
        super().__init__(env)
        self.codec = MessageCodec(env.action_space(env.possible_agents[0]), settings)

    def action_space(self, agent: str) -> spaces.Space:
        return self.codec.space

    def step(self, actions: dict) -> tuple[dict, dict, dict, dict, dict]:
        return self.env.step({agent: self.codec.decode(action) for agent, action in actions.items()})

    def action_masks(self) -> dict[str, np.ndarray]:
        masks = self.env.action_masks() if hasattr(self.env, "action_masks") else {}
        return {agent: self.codec.mask(mask) for agent, mask in masks.items() if mask is not None}
