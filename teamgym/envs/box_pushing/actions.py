"""The discrete primitive-action type of ``BoxPushing-v0`` (paper 004, sections 3.1 and 3.4).

Each robot has a :class:`~teamgym.control.primitives.PrimitiveExecutor`; the env passes it
in the command context, so the action type itself stays stateless.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gymnasium import spaces

from teamgym.control.primitives import Primitive, PrimitiveExecutor
from teamgym.envs.actions import ActionType, CommandContext


@dataclass(frozen=True)
class PrimitiveContext(CommandContext):
    """The robot's executor and the env's random stream (direction-change jitter)."""

    executor: PrimitiveExecutor | None = None
    rng: np.random.Generator | None = field(default=None, compare=False)


class PrimitiveAction(ActionType):
    """``Discrete(13)``: the primitives of :class:`~teamgym.control.primitives.Primitive`.

    Multi-cycle primitives (direction-change, following, side&push) keep the robot busy;
    actions chosen while it is busy are checked but ignored (the observation's ``busy``
    field says so).
    """

    name = "primitives"
    needs_context = True

    def space(self) -> spaces.Discrete:
        return spaces.Discrete(len(Primitive))

    def command(self, action, context: CommandContext) -> tuple[float, float]:
        if not isinstance(context, PrimitiveContext) or context.executor is None:
            raise TypeError("PrimitiveAction needs a PrimitiveContext with the robot's executor")
        return context.executor.command(int(action), context.rng)
