"""The one loader policy of teamgym's JSON data files: office maps, graph maps, scenarios.

:func:`load_json` reads a file (or :func:`parse_json` a string) within fixed limits and
turns every failure into a one-line :class:`MapError` that names the
file: more than :data:`MAX_BYTES` bytes, text that is not UTF-8 (a byte-order mark is
accepted), invalid JSON, nesting deeper than :data:`MAX_DEPTH`, an integer literal of more
than :data:`MAX_INT_DIGITS` digits, a number out of float range (``1e999``), the
non-standard literals ``NaN``/``Infinity``, and a key repeated within one object. The
parsers of each map kind then check the structure (types, missing keys) and raise
``MapError`` naming the item; env configs turn a ``MapError`` into a ``ConfigError`` naming
their ``map`` key.
"""

from __future__ import annotations

import json
import math
import numbers
from pathlib import Path
from typing import Any

__all__ = ["MAX_BYTES", "MAX_DEPTH", "MAX_INT_DIGITS", "MapError", "finite_number", "load_json", "parse_json"]

#: Largest data file read (bytes); the shipped maps are a few kB.
MAX_BYTES = 4 * 2**20
#: Deepest nesting of lists and objects (a map needs 4: top level, list, item, point).
MAX_DEPTH = 32
#: Most digits of an integer literal (coordinates in mm of a 1,000 km workspace need 9).
MAX_INT_DIGITS = 18


class MapError(ValueError):
    """A map file or map object is malformed or inconsistent; the message names the culprit."""


class _Refused(Exception):
    """A JSON text refused by the limits (raised inside the parser's hooks)."""


def _int(text: str) -> int:
    digits = len(text.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        raise _Refused(f"an integer literal of {digits} digits (at most {MAX_INT_DIGITS})")
    return int(text)


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _Refused(f"the number {text[:40]} is out of range")
    return value


def _constant(name: str) -> Any:
    raise _Refused(f"{name} is not a JSON number")


def _object(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _Refused(f"key {key[:40]!r} repeated in one object")
        out[key] = value
    return out


def _depth(value: Any) -> int:
    """Nesting depth of parsed JSON (0 for a scalar), iteratively."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, (list, dict)):
            level += 1
            deepest = max(deepest, level)
            if level > MAX_DEPTH:
                break
            stack.extend((child, level) for child in (item.values() if isinstance(item, dict) else item))
    return deepest


def parse_json(text: str, source: str) -> Any:
    """Parse JSON ``text`` within the limits; ``source`` names it in the ``MapError`` raised otherwise."""
    if len(text) > MAX_BYTES:
        raise MapError(f"{source}: not valid JSON (more than {MAX_BYTES} characters)")
    try:
        data = json.loads(text, parse_int=_int, parse_float=_float, parse_constant=_constant, object_pairs_hook=_object)
    except _Refused as error:
        raise MapError(f"{source}: not valid JSON ({error})") from None
    except RecursionError:
        raise MapError(f"{source}: not valid JSON (nested deeper than {MAX_DEPTH} levels)") from None
    except ValueError as error:  # JSONDecodeError
        raise MapError(f"{source}: not valid JSON ({str(error).splitlines()[0]})") from None
    if _depth(data) > MAX_DEPTH:
        raise MapError(f"{source}: not valid JSON (nested deeper than {MAX_DEPTH} levels)")
    return data


def load_json(path: Path, source: str, kind: str) -> Any:
    """Read and parse the JSON file ``path`` within the limits; errors name ``source`` and the ``kind`` of file."""
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_BYTES + 1)
    except OSError as error:
        raise MapError(f"{source}: cannot be read ({error.strerror or error})") from None
    if len(raw) > MAX_BYTES:
        raise MapError(f"{source}: not valid JSON (larger than {MAX_BYTES} bytes)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise MapError(f"{source}: not a JSON {kind} file (not UTF-8 text)") from None
    return parse_json(text, source)


def finite_number(value: Any) -> bool:
    """Whether ``value`` is a real, finite number (not a bool; an int too large for a float is not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False
