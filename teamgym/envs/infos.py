"""The fixed schema of ``infos[agent]``: every key is there from ``reset`` on, in every agent's dict.

A value not known yet (a time to goal before arrival, the time a target was first seen) holds
the key's sentinel ``InfoKey.missing``: -1 (times and indices are never negative). Not NaN:
PettingZoo's seed tests and Gymnasium's ``data_equivalence`` compare infos with ``==``, under
which NaN never equals itself. Categorical keys (a sector, place or task index) are labels,
not quantities: summaries never average them (:func:`baselines.evaluate.summarise` reads the
schema through :func:`baselines.episode.run_episode`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

InfoKind = Literal["metric", "categorical", "mask"]


@dataclasses.dataclass(frozen=True)
class InfoKey:
    """One key of ``infos[agent]``: its ``kind``, its value after reset, and whether that value means "not known yet"."""

    kind: InfoKind = "metric"
    #: The value at reset (and until known, when ``sentinel``).
    missing: Any = -1.0
    #: Whether ``missing`` stands for "not known yet" (summaries leave such values out) rather than a real value.
    sentinel: bool = True


#: A metric known from reset on (a count, a flag, a distance), starting at 0.
COUNT = InfoKey("metric", 0, sentinel=False)
#: A time or value that is -1.0 until known (a time to goal, the time a target was first seen).
UNKNOWN = InfoKey("metric", -1.0)
#: A categorical index, -1 until known; never averaged.
CATEGORICAL = InfoKey("categorical", -1)


def metrics(*names: str) -> dict[str, InfoKey]:
    """Metrics known from reset on (counts, flags, distances)."""
    return dict.fromkeys(names, COUNT)


def unknown(*names: str) -> dict[str, InfoKey]:
    """Metrics that hold -1.0 until known (e.g. the time a goal was reached)."""
    return dict.fromkeys(names, UNKNOWN)


def categorical(*names: str) -> dict[str, InfoKey]:
    """Categorical indices (-1 until known), never averaged."""
    return dict.fromkeys(names, CATEGORICAL)


def known_values(info: dict[str, Any], schema: dict[str, InfoKey]) -> dict[str, Any]:
    """``info`` without the values that stand for "not known yet" (``missing`` of a sentinel key)."""
    return {
        k: v for k, v in info.items() if not ((spec := schema.get(k)) is not None and spec.sentinel and _equal(v, spec.missing))
    }


def _equal(value: Any, missing: Any) -> bool:
    try:
        return not hasattr(value, "__len__") and bool(value == missing)
    except (TypeError, ValueError):
        return False
