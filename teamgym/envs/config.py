"""Frozen, validated configuration dataclasses for environments.

Every env has a config class derived from :class:`EnvConfig`. Validation runs in
``__post_init__``, so it holds however a config is built (the constructor,
``dataclasses.replace`` or ``from_kwargs``): values of the wrong type raise
:class:`ConfigError` naming the key, the value and the expected type (choices are listed),
and subclasses add range checks in :meth:`EnvConfig.check`. ``from_kwargs`` also rejects
unknown keys and parses values given as strings (``--set key=value``) with :func:`parse_value`.
"""

from __future__ import annotations

import ast
import dataclasses
import math
import types
import typing
from typing import Any, ClassVar, Literal, get_args, get_origin

import numpy as np


class ConfigError(ValueError):
    """An invalid environment configuration."""


def parse_value(text: str) -> Any:
    """Parse a command-line value: a Python literal (``5``, ``0.2``, ``True``, ``(1, 2)``) or a bare string."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _matches(value: Any, expected: Any) -> tuple[bool, Any]:
    """Whether ``value`` fits the annotation ``expected``; returns ``(ok, converted_value)``.

    numpy scalars count as the Python number they hold (``np.int64(3)`` is an ``int``).
    """
    if isinstance(value, np.generic):
        value = value.item()
    origin = get_origin(expected)
    if expected is Any:
        return True, value
    if origin is Literal:
        return value in get_args(expected), value
    if origin in (typing.Union, types.UnionType):
        for option in get_args(expected):
            ok, converted = _matches(value, option)
            if ok:
                return True, converted
        return False, value
    if expected is type(None):
        return value is None, value
    if expected is bool:
        return isinstance(value, bool), value
    if expected is int:
        return isinstance(value, int) and not isinstance(value, bool), value
    if expected is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return True, float(value)
        return False, value
    if expected is str:
        return isinstance(value, str), value
    if origin is tuple:
        args = get_args(expected)
        if not isinstance(value, (tuple, list)):
            return False, value
        if len(args) == 2 and args[1] is Ellipsis:
            items = [_matches(v, args[0]) for v in value]
        elif len(args) == len(value):
            items = [_matches(v, a) for v, a in zip(value, args)]
        else:
            return False, value
        if all(ok for ok, _ in items):
            return True, tuple(v for _, v in items)
        return False, value
    return isinstance(value, expected), value


def _describe(expected: Any) -> str:
    """A readable form of an annotation; choices are listed."""
    if get_origin(expected) is Literal:
        return "one of " + ", ".join(repr(c) for c in get_args(expected))
    if get_origin(expected) in (typing.Union, types.UnionType):
        return " or ".join(_describe(a) for a in get_args(expected))
    return getattr(expected, "__name__", None) or str(expected).replace("typing.", "")


def _has_non_finite(value: Any) -> bool:
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, tuple):
        return any(_has_non_finite(v) for v in value)
    return False


#: The farthest a body may move in one physics substep (m): max speed × dt / substeps.
#: A fifth of a Khepera's radius; contacts are then resolved before bodies pass through each
#: other (at the default 2 mm per substep the deepest penetration is under 2 mm).
MAX_SUBSTEP_TRAVEL = 0.005

#: Bounds of every env's episode length (control steps) and control step Δt (s): an episode
#: of up to a billion steps, and a Δt no shorter than a tenth of a millisecond (below it, the
#: episode length derived from a time limit overflows long before physics means anything).
MAX_CYCLES = 10**9
MIN_DT = 1e-4


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """Settings shared by every environment.

    Attributes
    ----------
    max_cycles:
        Control steps before the episode is truncated.
    dt:
        Control step Δt in seconds (0.1 s in papers 001 and 004).
    substeps:
        Physics substeps per control step. 20 keeps the worst penetration of a robot driven
        at full wheel speed (0.4 m/s) into a wall under 2 mm (0.4 m/s × 5 ms); no body may
        move more than ``MAX_SUBSTEP_TRAVEL`` (5 mm) in one substep.
    coarse_substeps:
        Adaptive substeps (0: off, the default). A control step in which no contact can begin
        (every moving body's bounding box, grown by the distance a body at ``body_speed``
        covers in Δt plus margin, is clear of what it may collide with) is integrated in
        this many substeps instead of ``substeps``; contacts are still resolved with
        ``substeps``. The joint-driven motion differs slightly with the substep length, so
        trajectories are not those of ``coarse_substeps=0`` (``benchmarks/bench_adaptive_substeps.py``).
    obs_format:
        ``"flat"`` (one float32 vector per agent), ``"dict"`` (named, typed fields, and
        ``action_mask`` where the action type has masks; ``motion_mask`` when ``comm_dim`` makes
        the action a Dict) or ``"masked"`` (PettingZoo's form for masked envs:
        ``{"observation": <flat vector>, "action_mask": <int8 mask>}``; discrete action spaces
        only, all ones where the action type has no masks).
    comm_dim:
        Length of a learned message vector in [-1, 1] added to every action (0: none); the
        observation then gains the inbox fields ``inbox``, ``inbox_sender``, ``inbox_mask``.
    comm_range, comm_throughput, comm_latency, comm_byte_budget:
        The radio of :class:`teamgym.sim.channel.Channel`: range in m (None: unlimited),
        delivery probability, latency in control steps, bytes per robot per step (None: no limit).
    normalize_actions:
        Continuous actions as ``Box(-1, 1)`` on every axis, mapped linearly onto the action
        type's native range (:class:`teamgym.envs.actions.UnitScaled`); for RL. Scripted
        baselines act in native units and refuse it. A discrete action type cannot be built with it.
    fixed_agents:
        Keep ``agents`` equal to ``possible_agents`` (spare robots included) from reset until
        the team's episode ends, for engines that need a fixed agent list; robots not present
        (not yet added, or after their last step) observe zeros with the observation field
        ``present`` = 0, get reward 0 and have their actions ignored
        (:mod:`teamgym.envs.fixed_agents`). Off by default: ``agents`` holds the live robots.
    """

    max_cycles: int = 400
    dt: float = 0.1
    substeps: int = 20
    coarse_substeps: int = 0
    obs_format: Literal["flat", "dict", "masked"] = "flat"
    comm_dim: int = 0
    comm_range: float | None = None
    comm_throughput: float = 1.0
    comm_latency: int = 0
    comm_byte_budget: int | None = None
    normalize_actions: bool = False
    fixed_agents: bool = False

    #: Keys :attr:`cycle_limit` is derived from (named when it is out of range).
    cycle_limit_keys: ClassVar[tuple[str, ...]] = ("max_cycles",)
    #: Fastest speed (m/s) a body of the env can reach; bounds the substep length (see ``check_relations``).
    body_speed_keys: ClassVar[tuple[str, ...]] = ()
    default_body_speed: ClassVar[float] = 0.4

    def __post_init__(self) -> None:
        """Validate types and ranges however the config is built (constructor, ``replace``, ``from_kwargs``)."""
        hints = typing.get_type_hints(type(self))
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            ok, converted = _matches(value, hints[f.name])
            if not ok or _has_non_finite(converted):
                raise ConfigError(f"{type(self).__name__}: {f.name}={value!r} is invalid; expected {_describe(hints[f.name])}")
            if converted is not value:
                object.__setattr__(self, f.name, converted)
        self.check()
        self.check_relations()

    @classmethod
    def field_names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """Build a validated config; unknown keys or bad values raise :class:`ConfigError`.

        String values (from ``--set key=value``) are parsed as Python literals unless the key
        takes a string.
        """
        known = cls.field_names()
        unknown = sorted(set(kwargs) - set(known))
        if unknown:
            raise ConfigError(f"{cls.__name__}: unknown config key(s) {unknown}; valid keys are {known}")
        hints = typing.get_type_hints(cls)
        values = {}
        for key, value in kwargs.items():
            if isinstance(value, str) and hints[key] is not str and get_origin(hints[key]) is not Literal:
                value = parse_value(value)
            values[key] = value
        return cls(**values)

    @property
    def cycle_limit(self) -> int:
        """Control steps after which an episode is truncated (``max_cycles``; a task may derive it from a time limit)."""
        return self.max_cycles

    def body_speed(self) -> float:
        """The fastest body speed (m/s) this config allows: the max of ``body_speed_keys`` values."""
        return max([self.default_body_speed, *(float(getattr(self, k)) for k in self.body_speed_keys)])

    def check(self) -> None:
        """Each key's own range, whatever the other keys say; subclasses extend with ``super().check()``.

        Every key is range-checked here on its own, so an out-of-range value is reported under
        its own name before any check that ties keys together (:meth:`check_relations`) runs.
        """
        cycles = self.max_cycles
        require(self, "max_cycles", cycles is None or 1 <= cycles <= MAX_CYCLES, f"must be in [1, {MAX_CYCLES:.0e}]")
        require(self, "dt", MIN_DT <= self.dt <= 10, f"must be in [{MIN_DT}, 10] s")
        require(self, "substeps", 1 <= self.substeps <= 1000, "must be in [1, 1000]")
        require(self, "coarse_substeps", 0 <= self.coarse_substeps <= 1000, "must be in [0, 1000] (0: off)")
        require(self, "comm_dim", 0 <= self.comm_dim <= 1024, "must be in [0, 1024] (0: no learned message)")
        require(self, "comm_range", self.comm_range is None or self.comm_range >= 0, "must be >= 0 m or None (unlimited)")
        require(self, "comm_throughput", 0 <= self.comm_throughput <= 1, "must be in [0, 1]")
        require(self, "comm_latency", 0 <= self.comm_latency <= 1000, "must be in [0, 1000] steps")
        require(self, "comm_byte_budget", self.comm_byte_budget is None or self.comm_byte_budget >= 0, "must be >= 0 or None")

    def check_relations(self) -> None:
        """Checks that tie several keys together, run after every key's own range (:meth:`check`).

        Subclasses extend with ``super().check_relations()``; each message names every key
        involved (:func:`require_together`).
        """
        require_together(
            self,
            ("coarse_substeps", "substeps"),
            self.coarse_substeps <= self.substeps,
            "coarse_substeps must not exceed substeps",
        )
        travel = self.body_speed() * self.dt / self.substeps
        require_together(
            self,
            ("substeps", "dt", *self.body_speed_keys),
            travel <= MAX_SUBSTEP_TRAVEL + 1e-12,
            f"a body at {self.body_speed()} m/s would move {travel * 1000:.1f} mm per substep, more than "
            f"{MAX_SUBSTEP_TRAVEL * 1000:.0f} mm (raise substeps or lower dt)",
        )
        require_together(
            self,
            self.cycle_limit_keys,
            1 <= self.cycle_limit <= MAX_CYCLES,
            f"they give an episode of {self.cycle_limit} control steps; it must be in [1, {MAX_CYCLES:.0e}]",
        )

    def world_options(self) -> dict[str, Any]:
        """Keyword arguments of :class:`~teamgym.sim.world.World` for this config: Δt and the substep settings.

        The contact reach of adaptive substeps is the distance a body at ``body_speed`` covers
        in Δt (each of two moving bodies is grown by it), with a quarter more and one
        substep's travel as margin (Chipmunk's bounding boxes lag the bodies by up to one substep).
        """
        reach = 1.25 * self.body_speed() * self.dt + MAX_SUBSTEP_TRAVEL
        return {"dt": self.dt, "substeps": self.substeps, "coarse_substeps": self.coarse_substeps, "contact_reach": reach}

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def require(config: EnvConfig, key: str, condition: bool, message: str) -> None:
    """Raise :class:`ConfigError` naming ``key`` and its value unless ``condition`` holds."""
    if not condition:
        raise ConfigError(f"{type(config).__name__}: {key}={getattr(config, key)!r} is invalid; it {message}")


def require_together(config: EnvConfig, keys: tuple[str, ...], condition: bool, message: str) -> None:
    """Raise :class:`ConfigError` naming every one of ``keys`` with its value unless ``condition`` holds."""
    if not condition:
        named = list(dict.fromkeys(keys))
        values = ", ".join(f"{key}={getattr(config, key)!r}" for key in named)
        verdict = "is invalid" if len(named) == 1 else "do not fit together"
        raise ConfigError(f"{type(config).__name__}: {values} {verdict}; {message}")
