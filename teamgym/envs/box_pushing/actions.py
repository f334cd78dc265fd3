"""The discrete primitive-action type of ``BoxPushing-v0`` (paper 004, sections 3.1 and 3.4).

Each robot has a :class:`~teamgym.control.primitives.PrimitiveExecutor` (``env.executors``);
the action type itself stays stateless.
"""

from __future__ import annotations

from gymnasium import spaces

from teamgym.control.primitives import Primitive
from teamgym.envs.actions import ActionType


class PrimitiveAction(ActionType):
    """``Discrete(13)``: the primitives of :class:`~teamgym.control.primitives.Primitive`.

    Multi-cycle primitives (direction-change, following, side&push) keep the robot busy;
    actions chosen while it is busy are checked but ignored (the observation's ``busy``
    field says so).
    """

    name = "primitives"

    def space(self) -> spaces.Discrete:
        return spaces.Discrete(len(Primitive))

    def act(self, env, agent: str, action) -> tuple[float, float]:
        """The command of ``agent``'s primitive executor (``env.executors``); jitter from ``env.np_random``."""
        return env.executors[agent].command(int(action), env.np_random)

    def describe(self, action) -> str:
        return Primitive(int(action)).name
