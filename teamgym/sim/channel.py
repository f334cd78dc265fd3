"""A lossy radio between robots: range, throughput, latency and a per-step byte budget.

Model
-----
Robots exchange :class:`Message` records through a :class:`Channel`. Messages can be
env-generated (e.g. shared perception tuples) or agent-chosen (a learned ``comm_dim`` float
vector). Per control step, the environment

1. calls :meth:`Channel.send` any number of times (the message is queued for this step;
   :meth:`Channel.send_array` queues an env's own float32 array without copying it),
2. calls :meth:`Channel.deliver` once with the robots' positions, its own
   ``np.random.Generator`` and the step number, then reads :meth:`Channel.inbox`,
   :meth:`Channel.inbox_array` or :meth:`Channel.inbox_payloads` to build observations.

Inside, queued and delivered messages are plain tuples; :meth:`Channel.inbox` builds the
:class:`Message` records when it is read.

A message reaches a receiver (every *other* present robot for a broadcast, the recipient
otherwise) only if

* the receiver is within ``comm_range`` metres of the sender at send time (Euclidean
  distance ``<= comm_range``, positions as passed to the ``deliver`` of the sending step);
* an independent delivery draw succeeds with probability ``throughput``;
* the receiver is still present when the message arrives, ``latency`` control steps later;
* the receiver's inbox has room (``inbox_size`` messages per step; arrivals are ordered by
  sender index, then send order, and the ones past the limit are dropped).

A sender may queue at most ``byte_budget`` bytes per step; a send that would exceed it is
refused (``send`` returns ``False``). The budget starts afresh after each ``deliver``.

Units: distances in metres, sizes in bytes, latency in control steps.

Order of random draws
---------------------
``deliver`` takes the messages sent this step sorted by sender index (the order of
``agents``), then by send order; for each, the receivers in agent-index order. One
``rng.random()`` is drawn per (message, receiver) pair that passed the presence and range
checks, and the copy is delivered iff the draw is ``< throughput``. Nothing is drawn when
``throughput`` is exactly 0 or 1, so a perfect channel leaves the environment's random
stream untouched. The same generator state therefore gives the same deliveries.

Counters (per agent, for the episode)
-------------------------------------
Sender side: ``bytes_sent`` and ``messages_sent`` count accepted sends (one per message,
however many receivers); ``dropped[reason]`` counts lost copies of the agent's messages, one
per (message, receiver) pair, with reasons ``"range"``, ``"loss"``, ``"inbox"`` and
``"absent"`` (the sender, or an addressed recipient, was missing from the positions at
send time, or the receiver was missing at arrival), plus ``"budget"`` for refused sends.
Receiver side: ``messages_delivered`` and ``bytes_delivered`` count the copies that reached
the agent's inbox and their sizes.

All state is plain Python and numpy, so ``copy.deepcopy`` and ``pickle`` give a channel
that continues identically when fed the same generator state.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

#: Reasons a message copy (or, for ``"budget"``, a send) is dropped.
DROP_REASONS = ("budget", "range", "loss", "inbox", "absent")

_TRAFFIC = ("bytes_sent", "bytes_delivered", "messages_sent", "messages_delivered")
_DROPPED_KEYS = tuple(f"dropped_{reason}" for reason in DROP_REASONS)


def _as_int(value: Any, what: str) -> int:
    """``value`` as a Python int; ``TypeError`` naming ``what`` for bools, floats, strings."""
    if isinstance(value, bool):
        raise TypeError(f"{what} must be an integer, got {value!r}")
    try:
        return operator.index(value)
    except TypeError:
        raise TypeError(f"{what} must be an integer, got {value!r}") from None


@dataclass(frozen=True)
class ChannelConfig:
    """Parameters of the radio. Call :meth:`check` (``Channel`` does) to validate them."""

    comm_range: float = math.inf  #: m; receivers farther than this from the sender get nothing
    throughput: float = 1.0  #: delivery probability per message per receiver, in [0, 1]
    latency: int = 0  #: control steps between send and arrival (0: same step)
    byte_budget: float = math.inf  #: bytes a robot may send per step
    inbox_size: int = 64  #: messages kept per receiver per step

    def check(self) -> None:
        """Raise ``ValueError`` naming the first invalid field and its value."""
        self._require("comm_range", _is_number(self.comm_range) and self.comm_range >= 0, "must be a number >= 0")
        self._require("throughput", _is_number(self.throughput) and 0 <= self.throughput <= 1, "must be in [0, 1]")
        self._require("latency", _is_count(self.latency) and self.latency >= 0, "must be an integer >= 0")
        self._require("byte_budget", _is_number(self.byte_budget) and self.byte_budget >= 0, "must be a number >= 0")
        self._require("inbox_size", _is_count(self.inbox_size) and self.inbox_size >= 1, "must be an integer >= 1")

    def _require(self, key: str, condition: bool, message: str) -> None:
        if not condition:
            raise ValueError(f"ChannelConfig: {key}={getattr(self, key)!r} is invalid; it {message}")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) and not math.isnan(value)


def _is_count(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _payload_vector(payload: Any, sender: str) -> np.ndarray:
    """A read-only float32 copy of ``payload``; errors name the sender."""
    if np.iscomplexobj(payload):
        raise TypeError(f"Message payload from {sender!r} must be real, got complex values")
    try:
        with np.errstate(all="ignore"):
            vector = np.array(payload, dtype=np.float32)
    except (TypeError, ValueError):
        raise TypeError(f"Message payload from {sender!r} must be a numeric vector, got {payload!r}") from None
    if vector.ndim != 1:
        raise ValueError(f"Message payload from {sender!r} must be 1-D, got shape {vector.shape}")
    if not np.all(np.isfinite(vector)):
        i = int(np.flatnonzero(~np.isfinite(vector))[0])
        raise ValueError(f"Message payload from {sender!r} has non-finite values (as float32), first at [{i}]: {vector[i]}")
    vector.setflags(write=False)
    return vector


@dataclass(frozen=True, eq=False)
class Message:
    """One radio message. ``recipient=None`` is a broadcast; ``size`` defaults to ``payload.nbytes``.

    ``payload`` is stored as a read-only float32 copy. Equality compares all fields, the
    payload by value.
    """

    sender: str
    recipient: str | None
    payload: np.ndarray
    size: int = None  # type: ignore[assignment]  # resolved to payload.nbytes
    kind: str = "data"
    sent_step: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.sender, str) or not (self.recipient is None or isinstance(self.recipient, str)):
            raise TypeError(f"Message sender/recipient must be str (recipient: or None), got {self.sender!r}/{self.recipient!r}")
        payload = _payload_vector(self.payload, self.sender)
        size = payload.nbytes if self.size is None else _as_int(self.size, f"Message size from {self.sender!r}")
        if size < 0:
            raise ValueError(f"Message size from {self.sender!r} must be >= 0, got {size}")
        if not isinstance(self.kind, str):
            raise TypeError(f"Message kind from {self.sender!r} must be a str, got {self.kind!r}")
        object.__setattr__(self, "payload", payload)
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "sent_step", _as_int(self.sent_step, "Message sent_step"))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Message):
            return NotImplemented
        fields = ("sender", "recipient", "size", "kind", "sent_step")
        same = all(getattr(self, f) == getattr(other, f) for f in fields)
        return same and np.array_equal(self.payload, other.payload)

    def stamped(self, step: int) -> Message:
        """This message with ``sent_step=step`` (fields already validated: no second check or payload copy)."""
        clone = object.__new__(Message)
        clone.__dict__.update(self.__dict__)
        object.__setattr__(clone, "sent_step", int(step))
        return clone

    @classmethod
    def _trusted(cls, sender: str, recipient: str | None, payload: np.ndarray, size: int, kind: str, sent_step: int) -> Message:
        """A message from fields the channel has checked already (``payload`` read-only float32): no second check or copy."""
        message = object.__new__(cls)
        message.__dict__.update(sender=sender, recipient=recipient, payload=payload, size=size, kind=kind, sent_step=sent_step)
        return message

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # Rebuild through __init__ so that copies and unpickled messages keep a read-only payload.
        return (Message, (self.sender, self.recipient, self.payload, self.size, self.kind, self.sent_step))


class PackedInbox(NamedTuple):
    """An inbox as fixed-size arrays; rows past the arrivals are padding (mask 0)."""

    payload: np.ndarray  #: (capacity, width) float32; payloads left-aligned, zero-padded
    mask: np.ndarray  #: (capacity,) int8; 1 for a message, 0 for padding
    sender: np.ndarray  #: (capacity,) int32; sender's index in ``Channel.agents``, -1 for padding


#: A queued message inside the channel: (sender index, send order, recipient index or -1 for a
#: broadcast, read-only float32 payload, size in bytes, kind). Plain tuples, not :class:`Message`
#: records: the channel builds those only when :meth:`Channel.inbox` is read.
_Entry = tuple[int, int, int, np.ndarray, int, str]


class Channel:
    """Radio between the named agents; see the module docstring for the model."""

    def __init__(self, agents: Sequence[str], config: ChannelConfig | None = None) -> None:
        config = ChannelConfig() if config is None else config
        config.check()
        names = tuple(agents)
        if not names:
            raise ValueError("Channel needs at least one agent")
        for name in names:
            if not isinstance(name, str):
                raise TypeError(f"Channel agent names must be str, got {name!r}")
        if len(set(names)) != len(names):
            raise ValueError(f"Channel agent names must be unique, got {list(names)!r}")
        self.agents: tuple[str, ...] = names
        self.config = config
        self._index = {name: i for i, name in enumerate(names)}
        self.reset()

    # ------------------------------------------------------------------ state

    def reset(self) -> None:
        """Forget queued, in-flight and received messages and zero the episode counters."""
        n = len(self.agents)
        self._outbox: list[_Entry] = []  # sent this step, in send order
        self._in_flight: dict[int, list[tuple[int, int, int, _Entry, int]]] = {}  # due -> (sender, seq, receiver, entry, step)
        self._inboxes: list[list[tuple[_Entry, int]]] = [[] for _ in range(n)]  # (entry, sent step) per receiver
        self._filled = False  # whether any inbox holds a message
        self._spent = [0] * n  # bytes queued this step, per sender
        self._seq = 0
        self._last_step: int | None = None
        self._counts = {key: [0] * n for key in _TRAFFIC}
        self._dropped = {reason: [0] * n for reason in DROP_REASONS}

    @property
    def busy(self) -> bool:
        """Whether :meth:`deliver` has anything to do: messages queued or in flight, or inboxes to clear."""
        return bool(self._outbox or self._in_flight or self._filled)

    @property
    def used(self) -> bool:
        """Whether any message was sent (or refused) since the last :meth:`reset`."""
        return any(self._counts["messages_sent"]) or any(self._dropped["budget"])

    # ------------------------------------------------------------------ sending

    def send(self, sender: str, payload: Any, recipient: str | None = None, size: int | None = None, kind: str = "data") -> bool:
        """Queue a message for this step's :meth:`deliver`; ``False`` if the byte budget refuses it.

        Raises ``KeyError`` for unknown names, ``ValueError``/``TypeError`` for a bad payload,
        size or kind, before changing anything.
        """
        s = self._agent_index(sender, "sender")
        r = -1
        if recipient is not None:
            r = self._agent_index(recipient, "recipient")
            if recipient == sender:
                raise ValueError(f"Channel.send: {sender!r} cannot address a message to itself")
        message = Message(sender, recipient, payload, size, kind)
        return self._queue(s, r, message.payload, message.size, message.kind)

    def send_array(self, sender: str, payload: np.ndarray, size: int, kind: str) -> bool:
        """:meth:`send` of a broadcast whose ``payload`` is already a 1-D float32 array of finite values.

        For env-generated messages in the step loop: the array is kept, not copied, and made
        read-only (do not reuse it); its values are not checked (they must be finite).
        ``size`` must be an int >= 0 and ``kind`` a str. Raises ``KeyError`` for an unknown
        sender and ``TypeError``/``ValueError`` for a payload that is not such an array or a
        bad size or kind, before changing anything.
        """
        s = self._agent_index(sender, "sender")
        if type(payload) is not np.ndarray or payload.dtype.char != "f" or payload.ndim != 1:
            got = f"{payload.dtype} array of shape {payload.shape}" if isinstance(payload, np.ndarray) else type(payload).__name__
            raise TypeError(f"Channel.send_array: payload from {sender!r} must be a 1-D float32 numpy array, got {got}")
        if type(size) is not int:
            size = _as_int(size, f"Message size from {sender!r}")
        if size < 0:
            raise ValueError(f"Message size from {sender!r} must be >= 0, got {size}")
        if not isinstance(kind, str):
            raise TypeError(f"Message kind from {sender!r} must be a str, got {kind!r}")
        payload.setflags(write=False)
        return self._queue(s, -1, payload, size, kind)

    def _queue(self, s: int, r: int, payload: np.ndarray, size: int, kind: str) -> bool:
        if self._spent[s] + size > self.config.byte_budget:
            self._dropped["budget"][s] += 1
            return False
        self._spent[s] += size
        self._counts["bytes_sent"][s] += size
        self._counts["messages_sent"][s] += 1
        self._outbox.append((s, self._seq, r, payload, size, kind))
        self._seq += 1
        return True

    # ------------------------------------------------------------------ delivering

    def deliver(self, positions: Mapping[str, tuple[float, float]] | np.ndarray, rng: np.random.Generator, step: int) -> None:
        """Dispatch this step's messages and fill the inboxes with those due at ``step``.

        ``positions`` maps present agents to ``(x, y)`` (m), or is an ``(n_agents, 2)`` array in
        agent order whose non-finite rows mark absent agents. ``step`` must increase from
        call to call. Inboxes are cleared first; the byte budget starts afresh afterwards.
        """
        step = self._check_step(step)
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"Channel.deliver: rng must be a numpy Generator, got {type(rng).__name__}")
        where = self._parse_positions(positions)
        if self._filled:
            for inbox in self._inboxes:
                inbox.clear()
            self._filled = False
        arrivals = self._dispatch(where, rng, step)
        self._arrive(where, step, arrivals)
        self._outbox.clear()
        self._spent = [0] * len(self.agents)
        self._last_step = step

    def _check_step(self, step: Any) -> int:
        if type(step) is not int:
            step = _as_int(step, "Channel.deliver step")
        if self._last_step is not None and step <= self._last_step:
            raise ValueError(f"Channel.deliver: step={step} must be greater than the previous step {self._last_step}")
        return step

    def _parse_positions(self, positions: Any) -> list[tuple[float, float] | None]:
        """Position of every agent by index; ``None`` for absent agents."""
        n = len(self.agents)
        if isinstance(positions, np.ndarray):
            if positions.shape != (n, 2):
                raise ValueError(f"Channel.deliver: positions array must have shape ({n}, 2), got {positions.shape}")
            rows = positions.astype(float).tolist()
            return [(x, y) if math.isfinite(x) and math.isfinite(y) else None for x, y in rows]
        where: list[tuple[float, float] | None] = [None] * n
        for name, xy in positions.items():
            i = self._agent_index(name, "agent in positions")
            try:
                x, y = (float(v) for v in xy)
            except (TypeError, ValueError):
                raise ValueError(f"Channel.deliver: position of {name!r} must be (x, y), got {xy!r}") from None
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError(f"Channel.deliver: position of {name!r} must be finite, got {xy!r}")
            where[i] = (x, y)
        return where

    def _dispatch(self, where: list[tuple[float, float] | None], rng: np.random.Generator, step: int) -> list:
        """Check presence, range and loss of every copy sent this step; returns the copies due now, schedules the rest.

        Copies are ``(sender, seq, receiver, entry, sent step)`` in (sender, seq, receiver) order.
        """
        due = step + self.config.latency
        limit, p = self.config.comm_range, self.config.throughput
        unlimited = math.isinf(limit)
        dropped = self._dropped
        present = [r for r, xy in enumerate(where) if xy is not None]
        survivors = []
        outbox = self._outbox
        if any(outbox[k][0] > outbox[k + 1][0] for k in range(len(outbox) - 1)):
            outbox = sorted(outbox, key=lambda entry: entry[:2])  # by sender, then send order (seq grows)
        for entry in outbox:
            s = entry[0]
            origin = where[s]
            if origin is None:
                dropped["absent"][s] += 1
                continue
            if entry[2] < 0:
                receivers = [r for r in present if r != s]
            elif where[entry[2]] is None:
                dropped["absent"][s] += 1
                continue
            else:
                receivers = [entry[2]]
            for r in receivers:
                if not unlimited:
                    x, y = where[r]  # type: ignore[misc]  # receivers are present
                    if math.hypot(origin[0] - x, origin[1] - y) > limit:
                        dropped["range"][s] += 1
                        continue
                if p >= 1 or (p > 0 and rng.random() < p):
                    survivors.append((s, entry[1], r, entry, step))
                else:
                    dropped["loss"][s] += 1
        if due == step:
            return survivors
        if survivors:
            self._in_flight.setdefault(due, []).extend(survivors)
        return []

    def _arrive(self, where: list[tuple[float, float] | None], step: int, arrivals: list) -> None:
        """Move the copies due by ``step`` (``arrivals`` and those in flight) into the inboxes, up to ``inbox_size`` each."""
        if self._in_flight:
            for due in sorted(d for d in self._in_flight if d <= step):
                arrivals.extend(self._in_flight.pop(due))
            arrivals.sort(key=lambda copy: copy[:2])
        if not arrivals:
            return
        capacity, inboxes = self.config.inbox_size, self._inboxes
        delivered, received = self._counts["messages_delivered"], self._counts["bytes_delivered"]
        absent, full = self._dropped["absent"], self._dropped["inbox"]
        for s, _seq, r, entry, sent in arrivals:
            inbox = inboxes[r]
            if where[r] is None:
                absent[s] += 1
            elif len(inbox) >= capacity:
                full[s] += 1
            else:
                inbox.append((entry, sent))
                delivered[r] += 1
                received[r] += entry[4]
                self._filled = True

    # ------------------------------------------------------------------ reading

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickled or deep-copied: the payloads (new arrays) are made read-only again.

        The attributes are set one by one (not written into ``__dict__``): CPython 3.11 reads the
        attributes of an object whose ``__dict__`` was written to about 2.5 times slower.
        """
        for name, value in state.items():
            object.__setattr__(self, name, value)
        entries = [*self._outbox, *(c[3] for copies in self._in_flight.values() for c in copies)]
        entries += [entry for inbox in self._inboxes for entry, _sent in inbox]
        for entry in entries:
            entry[3].setflags(write=False)

    def _message(self, entry: _Entry, sent: int) -> Message:
        s, _seq, r, payload, size, kind = entry
        return Message._trusted(self.agents[s], None if r < 0 else self.agents[r], payload, size, kind, sent)

    def inbox(self, agent: str) -> list[Message]:
        """Messages that arrived at ``agent`` in the last :meth:`deliver`, by sender index then send order."""
        return [self._message(entry, sent) for entry, sent in self._inboxes[self._agent_index(agent, "agent")]]

    def inbox_payloads(self, agent: str, kind: str) -> list[tuple[int, np.ndarray]]:
        """``(sender index, payload)`` of the ``kind`` messages of :meth:`inbox`, in its order (payloads read-only)."""
        inbox = self._inboxes[self._agent_index(agent, "agent")]
        return [(entry[0], entry[3]) for entry, _sent in inbox if entry[5] == kind]

    def inbox_array(self, agent: str, width: int, capacity: int, kind: str | None = None) -> PackedInbox:
        """The first ``capacity`` messages of :meth:`inbox` (only ``kind`` ones if given) as arrays.

        Payloads longer than ``width`` raise ``ValueError``; shorter ones are zero-padded.
        """
        width, capacity = _as_int(width, "inbox_array width"), _as_int(capacity, "inbox_array capacity")
        if width < 0 or capacity < 0:
            raise ValueError(f"Channel.inbox_array: width={width} and capacity={capacity} must be >= 0")
        inbox = self._inboxes[self._agent_index(agent, "agent")]
        entries = [entry for entry, _sent in inbox if kind is None or entry[5] == kind][:capacity]
        packed = PackedInbox(
            payload=np.zeros((capacity, width), dtype=np.float32),
            mask=np.zeros(capacity, dtype=np.int8),
            sender=np.full(capacity, -1, dtype=np.int32),
        )
        for row, entry in enumerate(entries):
            payload = entry[3]
            if len(payload) > width:
                raise ValueError(
                    f"Channel.inbox_array: payload of length {len(payload)} from {self.agents[entry[0]]!r} exceeds width={width}"
                )
            packed.payload[row, : len(payload)] = payload
            packed.mask[row] = 1
            packed.sender[row] = entry[0]
        return packed

    @property
    def bytes_sent(self) -> np.ndarray:
        """Bytes of accepted sends per agent (index order of ``agents``), this episode."""
        return np.array(self._counts["bytes_sent"], dtype=np.int64)

    @property
    def bytes_delivered(self) -> np.ndarray:
        """Bytes received into each agent's inbox, this episode."""
        return np.array(self._counts["bytes_delivered"], dtype=np.int64)

    @property
    def messages_sent(self) -> np.ndarray:
        """Accepted sends per agent, this episode (one per message, whatever the receivers)."""
        return np.array(self._counts["messages_sent"], dtype=np.int64)

    @property
    def messages_delivered(self) -> np.ndarray:
        """Messages received into each agent's inbox, this episode."""
        return np.array(self._counts["messages_delivered"], dtype=np.int64)

    @property
    def dropped(self) -> dict[str, np.ndarray]:
        """Dropped copies (refused sends for ``"budget"``) per reason, counted on the sender."""
        return {reason: np.array(counts, dtype=np.int64) for reason, counts in self._dropped.items()}

    @property
    def messages_dropped(self) -> np.ndarray:
        """All drops per sender, summed over the reasons."""
        return np.array([sum(per) for per in zip(*self._dropped.values())], dtype=np.int64)

    @staticmethod
    def stat_keys() -> tuple[str, ...]:
        """The keys of :meth:`stats`, in its order."""
        return (*_TRAFFIC, "messages_dropped", *(f"dropped_{reason}" for reason in DROP_REASONS))

    def stats(self, agent: str) -> dict[str, int]:
        """The agent's episode counters as plain ints, for env infos."""
        i = self._agent_index(agent, "agent")
        out = {key: counts[i] for key, counts in self._counts.items()}
        drops = [counts[i] for counts in self._dropped.values()]
        out["messages_dropped"] = sum(drops)
        out.update(zip(_DROPPED_KEYS, drops))
        return out

    def _agent_index(self, name: Any, role: str) -> int:
        try:
            return self._index[name]
        except (KeyError, TypeError):
            raise KeyError(f"Channel: unknown {role} {name!r}; agents are {list(self.agents)!r}") from None
