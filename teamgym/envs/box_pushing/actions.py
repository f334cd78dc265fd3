"""The discrete primitive-action type of ``BoxPushing-v0`` (paper 004, sections 3.1 and 3.4).

The action type owns each robot's :class:`~teamgym.control.primitives.PrimitiveExecutor`
(the robot's controller, per episode: :meth:`PrimitiveAction.begin`); it reads the task
only through :class:`PrimitiveTask` (the env's random stream, for the direction-change
jitter), and the task hands each sensed robot's proximity and encoder readings to
:meth:`PrimitiveAction.observe`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from gymnasium import spaces

from teamgym.control.primitives import Primitive, PrimitiveExecutor, PrimitiveParams
from teamgym.envs.actions import ActionType

__all__ = ["PrimitiveAction", "PrimitiveTask"]


class PrimitiveTask(Protocol):
    """What :class:`PrimitiveAction` reads of its task."""

    #: Draws the jitter of a direction-change (section 3.1).
    np_random: np.random.Generator


class PrimitiveAction(ActionType):
    """``Discrete(13)``: the primitives of :class:`~teamgym.control.primitives.Primitive`.

    Multi-cycle primitives (direction-change, following, side&push) keep the robot busy;
    actions chosen while it is busy are checked but ignored (the observation's ``busy``
    field says so).
    """

    name = "primitives"

    def __init__(self, params: PrimitiveParams) -> None:
        self.params = params
        #: Each robot's executor in the current episode (``begin``).
        self.executors: dict[str, PrimitiveExecutor] = {}

    def space(self) -> spaces.Discrete:
        return spaces.Discrete(len(Primitive))

    def begin(self, agents: Sequence[str]) -> None:
        """A new episode: a fresh executor per robot."""
        self.executors = {a: PrimitiveExecutor(self.params) for a in agents}

    def observe(self, agent: str, proximity: np.ndarray, encoders: np.ndarray) -> None:
        """``agent``'s readings after a control step (:meth:`PrimitiveExecutor.observe`)."""
        self.executors[agent].observe(proximity, encoders)

    def cancel(self, agent: str) -> None:
        """``agent`` left (removed, broken down): its running program is abandoned."""
        self.executors[agent].cancel()

    def busy(self, agents: Sequence[str]) -> list[bool]:
        """Whether each of ``agents`` runs a multi-cycle primitive."""
        executors = self.executors
        return [executors[a].busy for a in agents]

    def act(self, env: PrimitiveTask, agent: str, action) -> tuple[float, float]:
        """The command of ``agent``'s executor; jitter from ``env.np_random``."""
        return self.executors[agent].command(int(action), env.np_random)

    def describe(self, action) -> str:
        return Primitive(int(action)).name
