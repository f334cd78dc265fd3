"""Observation layouts with named fields, and strict checking of incoming actions."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from gymnasium import spaces


class ObservationLayout:
    """A flat float32 observation made of named fields.

    ``fields`` is a sequence of ``(name, shape)``; :meth:`space` is the flat ``Box`` SB3
    trains on and :meth:`decode` turns a flat vector back into a dict of shaped arrays.
    """

    def __init__(self, fields: Sequence[tuple[str, tuple[int, ...]]]) -> None:
        self.fields = [(name, tuple(shape)) for name, shape in fields]
        self.slices: dict[str, slice] = {}
        self.shapes: dict[str, tuple[int, ...]] = {}
        start = 0
        for name, shape in self.fields:
            size = int(np.prod(shape)) if shape else 1
            self.slices[name] = slice(start, start + size)
            self.shapes[name] = shape
            start += size
        self.size = start

    def space(self) -> spaces.Box:
        return spaces.Box(-np.inf, np.inf, shape=(self.size,), dtype=np.float32)

    def decode(self, observation: np.ndarray) -> dict[str, np.ndarray]:
        """Split a flat observation into its named fields (views, not copies)."""
        observation = np.asarray(observation)
        if observation.shape[-1] != self.size:
            raise ValueError(f"observation has {observation.shape[-1]} values, the layout expects {self.size}")
        lead = observation.shape[:-1]
        return {name: observation[..., s].reshape(*lead, *self.shapes[name]) for name, s in self.slices.items()}

    def view(self, buffer: np.ndarray, name: str) -> np.ndarray:
        """Writable view of field ``name`` inside a flat ``buffer``."""
        return buffer[self.slices[name]].reshape(self.shapes[name])


def check_action(agent: str, action, space: spaces.Space):
    """Return ``action`` converted for ``space`` or raise a clear error naming the agent.

    Rejects NaN and infinite values, wrong shapes and values outside the space.
    """
    if isinstance(space, spaces.Discrete):
        if isinstance(action, (bool, np.bool_)):
            raise TypeError(f"action for {agent!r} must be an integer in [0, {space.n}), got {action!r}")
        scalar = np.asarray(action)
        if scalar.shape not in ((), (1,)) or not np.issubdtype(scalar.dtype, np.integer):
            if scalar.shape in ((), (1,)) and np.issubdtype(scalar.dtype, np.floating):
                value = float(scalar.reshape(()))
                if np.isfinite(value) and value.is_integer():
                    scalar = np.asarray(int(value))
                else:
                    raise ValueError(f"action for {agent!r} must be an integer in [0, {space.n}), got {action!r}")
            else:
                raise TypeError(f"action for {agent!r} must be an integer in [0, {space.n}), got {action!r}")
        value = int(scalar.reshape(()))
        if not space.start <= value < space.start + space.n:
            raise ValueError(
                f"action for {agent!r} is {value}, outside Discrete({space.n}) = [{space.start}, {space.start + space.n})"
            )
        return value
    if isinstance(space, spaces.Box):
        try:
            raw = np.asarray(action)
        except (TypeError, ValueError):
            raise TypeError(f"action for {agent!r} must be numeric with shape {space.shape}, got {action!r}") from None
        if raw.dtype.kind not in "biuf":
            raise TypeError(f"action for {agent!r} must be real numbers with shape {space.shape}, got {action!r}")
        array = raw.astype(np.float64, copy=True)
        if array.shape != space.shape:
            raise ValueError(f"action for {agent!r} has shape {array.shape}, expected {space.shape} (space {space})")
        values = array.ravel().tolist()
        # One pass: NaN fails every comparison, so in-bounds implies finite.
        if all(lo <= v <= hi for v, lo, hi in zip(values, _bounds(space)[0], _bounds(space)[1])):
            return array
        if not all(np.isfinite(values)):
            raise ValueError(f"action for {agent!r} contains NaN or infinite values: {values}")
        raise ValueError(
            f"action for {agent!r} is {values}, outside the space bounds low={space.low.tolist()} high={space.high.tolist()}"
        )
    raise TypeError(f"unsupported action space {space!r} for {agent!r}")


_BOUNDS_CACHE: dict[int, tuple[spaces.Box, list[float], list[float]]] = {}


def _bounds(space: spaces.Box) -> tuple[list[float], list[float]]:
    """Flat lower and upper bounds of a Box as Python floats (cached per space object)."""
    cached = _BOUNDS_CACHE.get(id(space))
    if cached is None or cached[0] is not space:
        cached = (space, space.low.ravel().astype(float).tolist(), space.high.ravel().astype(float).tolist())
        _BOUNDS_CACHE[id(space)] = cached
    return cached[1], cached[2]
