"""The messages of paper 003's protocol (section 5) as integer records in a fixed-size vector.

A message is a vector of ``message_len`` int32 values holding records back to back, each
``[kind, n, v_1 … v_n]``, then ``-1`` padding. Places are indices into the map's places.

=========  ====  ==========================================  ================================
kind       code  values                                      sent when
=========  ====  ==========================================  ================================
PATH       1     expansions, p_0 … p_k (robot_0 → robot_1)    Agent 1 assembled a whole path
REPLAN     2     present place, a, b (the blocked way)        Step 6: the next way is blocked
PRESENT    3     present place                                Phase 1 / after a re-plan request
NEXT       4     next place                                   Step 8
BLOCKED    5     a, b                                         Step 5: a blocked way was detected
=========  ====  ==========================================  ================================

The env reads the PATH records it carries to score plans (``optimality``, ``replans``,
``expansions``); the channel charges 4 bytes per value up to the last record (padding is free).
The channel carries payloads as float32, which holds integers exactly up to
:data:`MESSAGE_VALUE_MAX` (2²⁴); a received value saturates there (the ``messages`` field's bound).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from enum import IntEnum

import numpy as np

#: Largest message value a receiver observes: float32 payloads hold integers exactly up to 2**24.
MESSAGE_VALUE_MAX = 2**24


class Kind(IntEnum):
    PATH = 1
    REPLAN = 2
    PRESENT = 3
    NEXT = 4
    BLOCKED = 5


Record = tuple[Kind, tuple[int, ...]]


def encode(records: Iterable[Record], length: int) -> np.ndarray:
    """Records packed into an int32 vector of ``length`` (ValueError if they do not fit)."""
    values: list[int] = []
    for kind, args in records:
        values += [int(kind), len(args), *(int(a) for a in args)]
    if len(values) > length:
        raise ValueError(f"message of {len(values)} values does not fit message_len={length}")
    out = np.full(length, -1, dtype=np.int32)
    out[: len(values)] = values
    return out


def decode(message: Sequence[int] | np.ndarray) -> list[Record]:
    """The well-formed records of a message, in order; decoding stops at padding or a malformed record."""
    values = [int(v) for v in np.asarray(message).ravel()]
    records: list[Record] = []
    i = 0
    while i + 1 < len(values) and values[i] > 0:
        kind, n = values[i], values[i + 1]
        if kind not in Kind._value2member_map_ or n < 0 or i + 2 + n > len(values):
            break
        records.append((Kind(kind), tuple(values[i + 2 : i + 2 + n])))
        i += 2 + n
    return records


def used_length(message: np.ndarray) -> int:
    """Values up to the end of the last well-formed record (what the radio transmits)."""
    return sum(2 + len(args) for _, args in decode(message))
