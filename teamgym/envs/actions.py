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

    def commands(self, actions: np.ndarray) -> np.ndarray | None:
        """:meth:`act` for many checked actions at once (rows of ``actions``): ``(R, 2)`` commands ``(v, ω)``.

        ``None`` when the type needs its env per robot (a batch then calls :meth:`act` row by row).
        The values equal :meth:`act`'s exactly, so a batched env steps as the single env does.
        """
        return None

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

    def commands(self, actions: np.ndarray) -> np.ndarray:
        return np.asarray(actions, dtype=np.float64)[:, :2]


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

    def commands(self, actions: np.ndarray) -> np.ndarray:
        left, right = np.asarray(actions, dtype=np.float64).T
        return np.stack(body_command(left, right, self.spec.wheel_base), axis=1)


class UnitScaled(ActionType):
    """A continuous type with every action dimension rescaled to [-1, 1] (config ``normalize_actions``).

    Action ``a`` in ``Box(-1, 1)`` drives the robot as the wrapped type's action
    ``low + (a + 1)·(high − low)/2``, so a policy whose outputs are unit-scaled (SB3's and
    RLlib's Gaussian policies start at mean 0, std 1) covers the whole range on every axis,
    whatever the units (m/s beside rad/s). Everything else is the wrapped type's.
    """

    def __init__(self, inner: ActionType) -> None:
        space = inner.space()
        if not isinstance(space, spaces.Box):
            raise TypeError(f"action type {inner.name!r} is not continuous ({type(space).__name__}); only Box actions rescale")
        self.inner = inner
        self.name = inner.name
        self.is_macro = inner.is_macro
        self.has_masks = inner.has_masks
        self.low = space.low.astype(np.float64)
        self.half_range = (space.high.astype(np.float64) - self.low) / 2
        self.shape = space.shape

    def native(self, action: Any) -> np.ndarray:
        """The wrapped type's action for unit-scaled ``action``."""
        return self.low + (np.asarray(action, dtype=np.float64) + 1.0) * self.half_range

    def unit(self, native: Any) -> np.ndarray:
        """The unit-scaled action for the wrapped type's ``native`` action (inverse of :meth:`native`)."""
        return ((np.asarray(native, dtype=np.float64) - self.low) / self.half_range - 1.0).astype(np.float32)

    def space(self) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, shape=self.shape, dtype=np.float32)

    def start(self, env: TeamEnv, actions: dict[str, Any]) -> None:
        self.inner.start(env, {agent: self.native(action) for agent, action in actions.items()})

    def act(self, env: TeamEnv, agent: str, action: Any) -> tuple[float, float]:
        return self.inner.act(env, agent, self.native(action))

    def commands(self, actions: np.ndarray) -> np.ndarray | None:
        return self.inner.commands(self.native(actions))

    def stage_over(self, env: TeamEnv) -> bool:
        return self.inner.stage_over(env)

    def describe(self, action: Any) -> str:
        return f"{action!r} (unit-scaled; {self.inner.describe(self.native(action))})"


class WithMessage(ActionType):
    """A motion action plus a message: ``Dict(motion=..., message=...)``.

    ``start`` hands every agent's message to :meth:`send` (which puts it on the env's
    communication channel, :class:`teamgym.sim.channel.Channel`) and the motion part to the
    wrapped type unchanged; everything else is the wrapped type's. The base form is the
    learned message of ``comm_dim``: ``Box(-1, 1, (comm_dim,))``, broadcast as kind
    ``"learned"``. A task's own message format subclasses it (``motion_key``,
    :meth:`message_space`, :meth:`send`).
    """

    motion_key = "motion"

    def __init__(self, motion: ActionType, length: int) -> None:
        self.motion = motion
        self.length = int(length)
        self.name = motion.name
        self.is_macro = motion.is_macro
        self.has_masks = motion.has_masks

    def message_space(self) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, shape=(self.length,), dtype=np.float32)

    def send(self, env: TeamEnv, agent: str, message: Any) -> None:
        env.channel.send(agent, np.asarray(message, dtype=np.float32), kind="learned")

    def space(self) -> spaces.Dict:
        return spaces.Dict({self.motion_key: self.motion.space(), "message": self.message_space()})

    def start(self, env: TeamEnv, actions: dict[str, Any]) -> None:
        key = self.motion_key
        for agent, action in actions.items():
            self.send(env, agent, action["message"])
        self.motion.start(env, {agent: action[key] for agent, action in actions.items()})

    def act(self, env: TeamEnv, agent: str, action: Any) -> tuple[float, float]:
        return self.motion.act(env, agent, action[self.motion_key])

    def stage_over(self, env: TeamEnv) -> bool:
        return self.motion.stage_over(env)

    def mask(self, env: TeamEnv, agent: str) -> np.ndarray | None:
        return self.motion.mask(env, agent)

    def mask_index(self, action: Any) -> int:
        return self.motion.mask_index(action[self.motion_key])

    def masked_space(self, space: spaces.Space) -> spaces.Space:
        return self.motion.masked_space(space[self.motion_key])

    def info_mask(self, mask: np.ndarray) -> Any:
        return {self.motion_key: self.motion.info_mask(mask), "message": None}

    def describe(self, action: Any) -> str:
        return self.motion.describe(action[self.motion_key] if isinstance(action, dict) else action)
