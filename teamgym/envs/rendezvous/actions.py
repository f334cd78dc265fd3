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

from teamgym.envs.actions import ActionType
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


class WithRecords(ActionType):
    """A move plus a protocol message (see the module docstring)."""

    def __init__(self, motion: ActionType, message_len: int) -> None:
        self.motion = motion
        self.message_len = int(message_len)
        self.name = motion.name
        self.is_macro = motion.is_macro
        self.has_masks = motion.has_masks

    def space(self) -> spaces.Dict:
        message = spaces.Box(-1, np.iinfo(np.int32).max, shape=(self.message_len,), dtype=np.int32)
        return spaces.Dict({"move": self.motion.space(), "message": message})

    def start(self, env, actions: dict[str, Any]) -> None:
        for agent, action in actions.items():
            message = np.asarray(action["message"], dtype=np.int32)
            used = used_length(message)
            if used:
                env.channel.send(agent, message[:used].astype(np.float32), size=4 * used, kind="protocol")
                env.note_message(agent, message[:used])
        self.motion.start(env, {agent: action["move"] for agent, action in actions.items()})

    def act(self, env, agent: str, action: Any) -> tuple[float, float]:
        return self.motion.act(env, agent, action["move"])

    def stage_over(self, env) -> bool:
        return self.motion.stage_over(env)

    def mask(self, env, agent: str) -> np.ndarray | None:
        return self.motion.mask(env, agent)

    def mask_index(self, action: Any) -> int:
        return self.motion.mask_index(action["move"])

    def masked_space(self, space: spaces.Space) -> spaces.Space:
        return self.motion.masked_space(space["move"])

    def info_mask(self, mask: np.ndarray) -> Any:
        return {"move": self.motion.info_mask(mask), "message": None}

    def describe(self, action: Any) -> str:
        return self.motion.describe(action["move"] if isinstance(action, dict) else action)
