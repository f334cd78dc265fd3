"""Action types of Rendezvous-v0: the next place (a macro action) and protocol messages.

``NextPlaceAction``: ``Discrete(D + 1)`` with ``D`` the map's largest degree. Slot ``k < D``
is the ``k``-th neighbour of the robot's place (neighbours in map order), slot ``D`` waits.
One ``step`` lasts until some moving robot reaches its next place (or no robot moves); a
robot already on a way finishes it, so while it moves only its way's slot and "wait"
(both: continue) are admissible. Ways the robot knows to be blocked are masked.

``WithRecords`` adds the protocol's message (:mod:`teamgym.envs.rendezvous.messages`):
``Dict(move=..., message=Box(-1, 2³¹−1, (message_len,), int32))``, broadcast through the
env's channel (kind ``"protocol"``) when it holds a record.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from teamgym.envs.actions import ActionType, WithMessage
from teamgym.envs.rendezvous.messages import used_length
from teamgym.envs.spaces import MaskedDiscrete


class NextPlaceAction(ActionType):
    """The next place to go to (a macro action run by the way-following controller)."""

    name = "next_place"
    is_macro = True
    has_masks = True

    def __init__(self, max_degree: int) -> None:
        self.max_degree = max_degree

    def space(self) -> MaskedDiscrete:
        return MaskedDiscrete(self.max_degree + 1)

    def start(self, env, actions: dict[str, Any]) -> None:
        env.start_moves(actions)

    def act(self, env, agent: str, action: Any) -> tuple[float, float]:
        return env.follow_way(agent)

    def stage_over(self, env) -> bool:
        return env.moves_over()

    def mask(self, env, agent: str) -> np.ndarray:
        return env.move_mask(agent)

    def describe(self, action: Any) -> str:
        return "wait" if int(action) == self.max_degree else f"neighbour slot {int(action)}"


class WithRecords(WithMessage):
    """A move plus a protocol message (see the module docstring)."""

    motion_key = "move"

    def message_space(self) -> spaces.Box:
        return spaces.Box(-1, np.iinfo(np.int32).max, shape=(self.length,), dtype=np.int32)

    def send(self, env, agent: str, message: Any) -> None:
        """Transmit the records only (4 bytes a value, no padding); the env scores PATH records."""
        values = np.asarray(message, dtype=np.int32)
        used = used_length(values)
        if used:
            env.channel.send(agent, values[:used].astype(np.float32), size=4 * used, kind="protocol")
            env.note_message(agent, values[:used])
