"""Scenario files (``teamgym/maps/data/scenarios``): paper 003's section 6 situations as data.

A scenario names a graph map (``graph``), the robots (``robots``: ``id``, ``agent`` number and
``start`` place), the blocked ways (``blocked``: ends ``a``, ``b``, ``from_step`` and where
they are ``detected``), the paper's ``plans`` and its ``meeting`` place. :func:`load_scenario`
reads one with the loader policy of every map file (:mod:`teamgym.maps.jsonfile`) and checks
the keys the experiments read; any failure is a :class:`~teamgym.maps.jsonfile.MapError`
naming the file and the item.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from teamgym.maps.jsonfile import MapError, load_json

SCENARIO_DIR = Path(__file__).resolve().parent / "data" / "scenarios"

#: Required keys and the JSON types of their values, per part of a scenario.
_TOP = {"name": str, "graph": str, "robots": list, "blocked": list, "plans": list, "meeting": str}
_ROBOT = {"id": str, "agent": int, "start": str}
_BLOCKED = {"a": str, "b": str, "from_step": int, "detected": list}
_DETECTED = {"step": int, "robot": str, "place": str}


def available_scenarios() -> list[str]:
    """Names of the scenarios shipped with teamgym."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.json"))


def _checked(source: str, where: str, item: Any, keys: dict[str, type]) -> dict:
    """``item`` if it is an object holding ``keys`` with values of their types (bools are no ints)."""
    if not isinstance(item, dict):
        raise MapError(f"{source}: {where}: expected an object, got {type(item).__name__}")
    for key, kind in keys.items():
        if key not in item:
            raise MapError(f"{source}: {where}: missing key {key!r}")
        value = item[key]
        if not isinstance(value, kind) or isinstance(value, bool) or (kind is str and not value):
            raise MapError(f"{source}: {where}.{key}: expected a {'non-empty string' if kind is str else kind.__name__}")
    return item


def load_scenario(name_or_path: str | Path) -> dict[str, Any]:
    """A shipped scenario by name (``"paper003_fig5"``) or a scenario file by path, checked (see the module docstring)."""
    path = Path(name_or_path)
    if isinstance(name_or_path, str) and name_or_path in available_scenarios():
        path = SCENARIO_DIR / f"{name_or_path}.json"
    if not path.is_file():
        raise MapError(f"no scenario {str(name_or_path)!r}: not a shipped scenario ({available_scenarios()}) nor a file")
    source = path.name if path.parent == SCENARIO_DIR else str(path)
    data = _checked(source, "top level", load_json(path, source, "scenario"), _TOP)
    for i, robot in enumerate(data["robots"]):
        _checked(source, f"robots[{i}]", robot, _ROBOT)
    for i, way in enumerate(data["blocked"]):
        _checked(source, f"blocked[{i}]", way, _BLOCKED)
        if way["from_step"] < 0 or not way["detected"]:
            raise MapError(f"{source}: blocked[{i}]: from_step must be >= 0 and detected must list a sighting")
        for k, seen in enumerate(way["detected"]):
            _checked(source, f"blocked[{i}].detected[{k}]", seen, _DETECTED)
    return data
