"""Frozen, validated configuration dataclasses for environments.

Every env has a config class derived from :class:`EnvConfig`. ``from_kwargs`` rejects
unknown keys and values of the wrong type with an error naming the key, the value and the
expected type; subclasses add range checks in :meth:`EnvConfig.check`. Values given as
strings (from the command line, ``--set key=value``) are parsed with :func:`parse_value`.
"""

from __future__ import annotations

import ast
import dataclasses
import math
import typing
from typing import Any, Literal, get_args, get_origin


class ConfigError(ValueError):
    """An invalid environment configuration."""


def parse_value(text: str) -> Any:
    """Parse a command-line value: a Python literal (``5``, ``0.2``, ``True``, ``(1, 2)``) or a bare string."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _matches(value: Any, expected: Any) -> tuple[bool, Any]:
    """Whether ``value`` fits the annotation ``expected``; returns ``(ok, converted_value)``."""
    origin = get_origin(expected)
    if expected is Any:
        return True, value
    if origin is Literal:
        return value in get_args(expected), value
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
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
        at full wheel speed (0.4 m/s) into a wall under 2 mm (0.4 m/s × 5 ms).
    """

    max_cycles: int = 400
    dt: float = 0.1
    substeps: int = 20

    @classmethod
    def field_names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """Build a validated config; unknown keys or bad values raise :class:`ConfigError`."""
        known = cls.field_names()
        unknown = sorted(set(kwargs) - set(known))
        if unknown:
            raise ConfigError(f"{cls.__name__}: unknown config key(s) {unknown}; valid keys are {known}")
        hints = typing.get_type_hints(cls)
        values = {}
        for key, value in kwargs.items():
            if isinstance(value, str) and hints[key] is not str and get_origin(hints[key]) is not Literal:
                value = parse_value(value)
            ok, converted = _matches(value, hints[key])
            if ok and isinstance(converted, float) and not math.isfinite(converted):
                ok = False
            if not ok:
                expected = getattr(hints[key], "__name__", None) or str(hints[key]).replace("typing.", "")
                raise ConfigError(f"{cls.__name__}: {key}={value!r} is invalid; expected {expected}")
            values[key] = converted
        config = cls(**values)
        config.check()
        return config

    def check(self) -> None:
        """Range checks; subclasses extend with ``super().check()``."""
        require(self, "max_cycles", self.max_cycles >= 1, "must be >= 1")
        require(self, "dt", self.dt > 0, "must be > 0")
        require(self, "substeps", 1 <= self.substeps <= 1000, "must be in [1, 1000]")

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def require(config: EnvConfig, key: str, condition: bool, message: str) -> None:
    """Raise :class:`ConfigError` naming ``key`` and its value unless ``condition`` holds."""
    if not condition:
        raise ConfigError(f"{type(config).__name__}: {key}={getattr(config, key)!r} is invalid; it {message}")
