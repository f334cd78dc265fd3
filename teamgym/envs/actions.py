"""Action types: how an agent's action drives its robot, for primitive and macro actions alike.

An env picks one :class:`ActionType` from its config (``action_type``). The base env calls it
in named phases of :meth:`teamgym.envs.base.TeamEnv.step`:

* ``start(env, actions)`` once per ``step`` with the checked actions of the live agents (a
  macro type assigns its tasks here);
* ``act(env, agent, action)`` in every control step: the body command ``(v, ω)`` in SI units;
* ``stage_over(env)`` after every control step of a macro type (``is_macro``): whether the
  ``step`` ends; a primitive type runs exactly one control step per ``step``;
* ``mask(env, agent)``: the admissible discrete actions now (``None``: every action is).

What a type needs from its env it reads through the env's public methods, so the base env
never branches on the action type.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from teamgym.sim.robot import RobotSpec, body_command

if TYPE_CHECKING:
    from teamgym.envs.base import TeamEnv


class ActionType(ABC):
    """Maps an agent's action to a body command ``(v, ω)``; see the module docstring."""

    name: str = ""
    #: Whether one ``step()`` runs several control steps (until :meth:`stage_over`).
    is_macro: bool = False
    #: Whether :meth:`mask` can return a mask (the env skips asking otherwise).
    has_masks: bool = False

    @abstractmethod
    def space(self) -> spaces.Space: ...

    def start(self, env: TeamEnv, actions: dict[str, Any]) -> None:
        """Called once per ``step`` with the checked actions, before the first control step."""
        return None

    @abstractmethod
    def act(self, env: TeamEnv, agent: str, action: Any) -> tuple[float, float]:
        """The body command ``(v, ω)`` (m/s, rad/s) of ``agent`` in the current control step."""

    def stage_over(self, env: TeamEnv) -> bool:
        """After a control step of a macro type: whether this ``step`` ends."""
        return True

    def mask(self, env: TeamEnv, agent: str) -> np.ndarray | None:
        """Admissible actions of ``agent`` now (int8, 1 = admissible), or ``None`` if all are."""
        return None

    def mask_index(self, action: Any) -> int:
        """The index into :meth:`mask` that ``action`` selects."""
        return int(action)

    def masked_space(self, space: spaces.Space) -> spaces.Space:
        """The part of this type's ``space`` that :meth:`mask` applies to."""
        return space

    def info_mask(self, mask: np.ndarray) -> Any:
        """``mask`` in the form ``space().sample(mask=...)`` takes (``infos[agent]["action_mask"]``)."""
        return mask

    def describe(self, action: Any) -> str:
        """A readable name of ``action`` for error messages."""
        return repr(action)


class VelocityAction(ActionType):
    """Continuous ``(v, ω)``: linear speed in m/s and angular speed in rad/s (CCW positive)."""

    name = "velocity"

    def __init__(self, spec: RobotSpec) -> None:
        self.v_max = spec.max_speed
        self.omega_max = spec.max_turn_rate

    def space(self) -> spaces.Box:
        high = np.array([self.v_max, self.omega_max], dtype=np.float32)
        return spaces.Box(-high, high, dtype=np.float32)

    def act(self, env: TeamEnv, agent: str, action: Any) -> tuple[float, float]:
        return float(action[0]), float(action[1])


class WheelSpeedAction(ActionType):
    """Continuous wheel rim speeds ``(v_L, v_R)`` in m/s, converted by eq. (6) of paper 001."""

    name = "wheels"

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec

    def space(self) -> spaces.Box:
        high = np.full(2, self.spec.max_wheel_speed, dtype=np.float32)
        return spaces.Box(-high, high, dtype=np.float32)

    def act(self, env: TeamEnv, agent: str, action: Any) -> tuple[float, float]:
        return body_command(float(action[0]), float(action[1]), self.spec.wheel_base)


class WithMessage(ActionType):
    """A motion action plus a learned message: ``Dict(motion=..., message=Box(-1, 1, (comm_dim,)))``.

    ``start`` broadcasts every agent's message through the env's communication channel
    (:class:`teamgym.sim.channel.Channel`, kind ``"learned"``); the motion part is handed to
    the wrapped type unchanged.
    """

    def __init__(self, motion: ActionType, comm_dim: int) -> None:
        self.motion = motion
        self.comm_dim = int(comm_dim)
        self.name = motion.name
        self.is_macro = motion.is_macro
        self.has_masks = motion.has_masks

    def space(self) -> spaces.Dict:
        message = spaces.Box(-1.0, 1.0, shape=(self.comm_dim,), dtype=np.float32)
        return spaces.Dict({"motion": self.motion.space(), "message": message})

    def start(self, env: TeamEnv, actions: dict[str, Any]) -> None:
        for agent, action in actions.items():
            env.channel.send(agent, np.asarray(action["message"], dtype=np.float32), kind="learned")
        self.motion.start(env, {agent: action["motion"] for agent, action in actions.items()})

    def act(self, env: TeamEnv, agent: str, action: Any) -> tuple[float, float]:
        return self.motion.act(env, agent, action["motion"])

    def stage_over(self, env: TeamEnv) -> bool:
        return self.motion.stage_over(env)

    def mask(self, env: TeamEnv, agent: str) -> np.ndarray | None:
        return self.motion.mask(env, agent)

    def mask_index(self, action: Any) -> int:
        return self.motion.mask_index(action["motion"])

    def masked_space(self, space: spaces.Space) -> spaces.Space:
        return self.motion.masked_space(space["motion"])

    def info_mask(self, mask: np.ndarray) -> Any:
        return {"motion": self.motion.info_mask(mask), "message": None}

    def describe(self, action: Any) -> str:
        return self.motion.describe(action["motion"]) if isinstance(action, dict) else self.motion.describe(action)
