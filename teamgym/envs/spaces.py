"""Observation layouts with typed, bounded fields, and strict checking of incoming actions.

An :class:`ObservationLayout` is a list of :class:`Field` (name, shape, dtype, bounds). Every env
offers two observation formats built from it (``obs_format`` in the config):

* ``"flat"``: one float32 vector, the fields concatenated in order (what SB3's ``MlpPolicy``
  takes); :meth:`ObservationLayout.decode` splits it back into named fields;
* ``"dict"``: a gymnasium ``Dict`` of the named fields, each a ``Box`` of its own dtype and
  bounds (vectors, uint8 images, grids, a message inbox and its validity mask).

:meth:`ObservationLayout.clip` saturates flat observations at the fields' bounds (every env
gives finite ones, :mod:`teamgym.envs.bounds`), so observations always lie in their space.

:class:`ActionChecker` validates an action against its space before the env changes anything
(``Discrete``, ``Box``, ``MultiDiscrete``, ``MultiBinary`` and nested ``Dict``/``Tuple``),
with errors that name the agent, the field and the value.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from gymnasium import spaces

ObsFormat = Literal["flat", "dict"]


@dataclass(frozen=True)
class Field:
    """One named observation field: ``shape``, element ``dtype`` and bounds ``[low, high]``.

    ``low`` and ``high`` are numbers or arrays that broadcast to ``shape`` (e.g. a pose
    ``(x, y, θ)`` with per-element bounds).
    """

    name: str
    shape: tuple[int, ...] = ()
    low: float | tuple[float, ...] = -np.inf
    high: float | tuple[float, ...] = np.inf
    dtype: type = np.float32

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``low`` and ``high`` as float64 arrays of the field's shape."""
        return (
            np.broadcast_to(np.asarray(self.low, dtype=np.float64), self.shape).copy(),
            np.broadcast_to(np.asarray(self.high, dtype=np.float64), self.shape).copy(),
        )

    @property
    def size(self) -> int:
        return int(np.prod(self.shape)) if self.shape else 1

    def space(self) -> spaces.Box:
        """The field as a gymnasium ``Box`` of its own dtype (infinite bounds only for floats)."""
        dtype = np.dtype(self.dtype)
        low, high = self.bounds()
        if dtype.kind in "iu":
            info = np.iinfo(dtype)
            low = np.where(np.isfinite(low), low, info.min)
            high = np.where(np.isfinite(high), high, info.max)
        return spaces.Box(low=low.astype(dtype), high=high.astype(dtype), shape=self.shape, dtype=dtype)


def _as_field(item: Field | tuple) -> Field:
    if isinstance(item, Field):
        return item
    name, shape, *rest = item
    return Field(name, tuple(shape), *rest)


class ObservationLayout:
    """Observation fields in order; see the module docstring for the two formats.

    ``fields`` holds :class:`Field` objects or ``(name, shape)`` pairs (float32, unbounded).
    """

    def __init__(self, fields: Sequence[Field | tuple]) -> None:
        self.fields: list[Field] = [_as_field(f) for f in fields]
        names = [f.name for f in self.fields]
        if len(set(names)) != len(names):
            raise ValueError(f"observation field names must be unique, got {names}")
        self.slices: dict[str, slice] = {}
        self.shapes: dict[str, tuple[int, ...]] = {}
        start = 0
        for f in self.fields:
            self.slices[f.name] = slice(start, start + f.size)
            self.shapes[f.name] = f.shape
            start += f.size
        self.size = start
        bounds = [f.bounds() for f in self.fields]
        self._low = np.concatenate([lo.ravel() for lo, _ in bounds] or [np.zeros(0)]).astype(np.float32)
        self._high = np.concatenate([hi.ravel() for _, hi in bounds] or [np.zeros(0)]).astype(np.float32)

    def extended(self, fields: Sequence[Field | tuple]) -> ObservationLayout:
        """A new layout with ``fields`` appended (e.g. a message inbox)."""
        return ObservationLayout([*self.fields, *fields])

    # -- spaces ------------------------------------------------------------------------
    def space(self, obs_format: ObsFormat = "flat") -> spaces.Space:
        """The observation space in ``obs_format``."""
        if obs_format == "flat":
            return self.flat_space()
        if obs_format == "dict":
            return self.dict_space()
        raise ValueError(f"obs_format must be 'flat' or 'dict', got {obs_format!r}")

    def flat_space(self) -> spaces.Box:
        """A float32 ``Box`` of ``size`` values with every field's bounds."""
        return spaces.Box(self._low.copy(), self._high.copy(), dtype=np.float32)

    def clip(self, out: np.ndarray) -> np.ndarray:
        """Saturate flat observations ``out`` (``(..., size)``, float32) at the field bounds, in place; returns ``out``.

        Only values outside the bounds change (NaN stays NaN), so in-bounds values keep their bits.
        """
        low, high = self._low, self._high
        inside = (out >= low) & (out <= high)
        if not inside.all():
            np.copyto(out, np.clip(out, low, high), where=~inside & ~np.isnan(out))
        return out

    def dict_space(self) -> spaces.Dict:
        """A ``Dict`` of every field's ``Box`` (in field order)."""
        return spaces.Dict({f.name: f.space() for f in self.fields})

    # -- conversion --------------------------------------------------------------------
    def to_dict(self, row: np.ndarray) -> dict[str, np.ndarray]:
        """A flat observation as a dict of fields (copies, cast to each field's dtype)."""
        out = {}
        for f in self.fields:
            value = row[self.slices[f.name]].reshape(f.shape)
            out[f.name] = value.astype(f.dtype) if f.dtype is not np.float32 else value.copy()
        return out

    def decode(self, observation: np.ndarray | Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Named fields of a flat observation (views, not copies), or of a dict one (as given)."""
        if isinstance(observation, Mapping):
            missing = [f.name for f in self.fields if f.name not in observation]
            if missing:
                raise ValueError(f"observation lacks field(s) {missing}")
            return {f.name: np.asarray(observation[f.name]) for f in self.fields}
        observation = np.asarray(observation)
        if observation.shape[-1] != self.size:
            raise ValueError(f"observation has {observation.shape[-1]} values, the layout expects {self.size}")
        lead = observation.shape[:-1]
        return {name: observation[..., s].reshape(*lead, *self.shapes[name]) for name, s in self.slices.items()}

    def view(self, buffer: np.ndarray, name: str) -> np.ndarray:
        """Writable view of field ``name`` inside a flat ``buffer``."""
        return buffer[self.slices[name]].reshape(self.shapes[name])


# -- actions ------------------------------------------------------------------------------


class MaskedDiscrete(spaces.Discrete):
    """``Discrete(n)`` whose ``sample()`` without a mask draws an admissible action.

    The env keeps ``live_mask`` equal to the agent's current action mask (also in
    ``infos[agent]["action_mask"]``); ``sample(mask=...)`` behaves as in gymnasium.
    """

    def __init__(self, n: int, seed: int | None = None) -> None:
        super().__init__(n, seed=seed)
        self.live_mask = np.ones(n, dtype=np.int8)

    def sample(self, mask: np.ndarray | None = None, probability: np.ndarray | None = None) -> np.int64:
        if mask is None and probability is None:
            mask = self.live_mask
        if probability is None:  # gymnasium 1.0's Discrete.sample has no ``probability``
            return super().sample(mask=mask)
        return super().sample(mask=mask, probability=probability)


class ActionChecker:
    """Validates actions for one space; built once per agent, called every step.

    ``check(agent, action)`` returns the action converted for the env (``int`` for
    ``Discrete``, a float64 array for ``Box``, dicts and tuples for composite spaces) or raises
    ``TypeError``/``ValueError`` naming the agent, the field path and the value. Box bounds are
    compared as the space's float32 values, exactly as ``space.contains`` does.
    """

    def __init__(self, space: spaces.Space) -> None:
        self.space = space
        self._check = _checker(space)

    def check(self, agent: str, action: Any) -> Any:
        return self._check(agent, "", action)


class ActionRowsChecker:
    """Validates a whole array of actions for one Box or Discrete space (a batch of env copies).

    ``check(actions, names)`` takes ``(R, *shape)`` actions (``(R,)`` for ``Discrete``) and the
    name of each row's agent, and returns them as float64 (Box) or int64 (Discrete). It accepts
    exactly what :class:`ActionChecker` accepts row by row; the rows are tested in one numpy
    pass, and a failing row is handed to :class:`ActionChecker`, whose error names its agent.
    """

    def __init__(self, space: spaces.Space) -> None:
        if not isinstance(space, (spaces.Box, spaces.Discrete)):
            raise TypeError(f"ActionRowsChecker needs a Box or Discrete space, got {space!r}")
        self.space = space
        self._rows = ActionChecker(space)
        self._shape = space.shape if isinstance(space, spaces.Box) else ()

    def check(self, actions: Any, names: list[str]) -> np.ndarray:
        space = self.space
        try:
            raw = np.asarray(actions)
        except (TypeError, ValueError):
            raise TypeError(f"actions must be a numeric array of shape ({len(names)}, *{self._shape}), got {actions!r}") from None
        if raw.shape != (len(names), *self._shape):
            raise ValueError(f"actions have shape {raw.shape}, expected {(len(names), *self._shape)} for the space {space}")
        if raw.dtype.kind in "biuf":
            if isinstance(space, spaces.Box):
                with np.errstate(over="ignore"):  # a huge float64 casts to inf: out of bounds, refused below
                    cast = raw.astype(space.dtype)
                if np.all(cast >= space.low) and np.all(cast <= space.high):  # NaN fails both: in bounds is finite
                    return raw.astype(np.float64)
            else:
                values = raw.astype(np.float64)
                start, n = int(space.start), int(space.n)
                if np.all((values >= start) & (values < start + n) & (values == np.floor(values))) and raw.dtype.kind != "b":
                    return raw.astype(np.int64)
        rows = raw.tolist() if raw.dtype == object else raw  # object rows as plain values, as a single agent's action
        checked = [self._rows.check(name, action) for name, action in zip(names, rows)]  # raises naming the row
        return np.array(checked, dtype=np.float64 if isinstance(space, spaces.Box) else np.int64)


def check_action(agent: str, action: Any, space: spaces.Space) -> Any:
    """One-off form of :class:`ActionChecker` (builds the checker each call)."""
    return ActionChecker(space).check(agent, action)


def _where(agent: str, path: str) -> str:
    return f"action for {agent!r}" + (f" at {path}" if path else "")


def _checker(space: spaces.Space):
    if isinstance(space, spaces.Discrete):
        return _discrete_checker(space)
    if isinstance(space, spaces.Box):
        return _box_checker(space)
    if isinstance(space, spaces.MultiBinary):
        return _box_checker(spaces.Box(0, 1, shape=space.shape, dtype=np.int8), integer=True)
    if isinstance(space, spaces.MultiDiscrete):
        return _box_checker(spaces.Box(space.start, space.start + space.nvec - 1, dtype=np.int64), integer=True)
    if isinstance(space, spaces.Dict):
        return _dict_checker(space)
    if isinstance(space, spaces.Tuple):
        return _tuple_checker(space)

    def unsupported(agent, path, action):
        raise TypeError(f"{_where(agent, path)}: unsupported action space {space!r}")

    return unsupported


def _discrete_checker(space: spaces.Discrete):
    n, start = int(space.n), int(space.start)

    def check(agent: str, path: str, action: Any) -> int:
        if isinstance(action, (bool, np.bool_)):
            raise TypeError(f"{_where(agent, path)} must be an integer in [{start}, {start + n}), got {action!r}")
        if isinstance(action, int):
            value = action
        else:
            scalar = np.asarray(action) if not isinstance(action, (str, bytes)) else np.asarray(None, dtype=object)
            if scalar.shape not in ((), (1,)) or scalar.dtype.kind not in "iuf":
                raise TypeError(f"{_where(agent, path)} must be an integer in [{start}, {start + n}), got {action!r}")
            number = scalar.reshape(()).item()
            if isinstance(number, float) and not (np.isfinite(number) and number.is_integer()):
                raise ValueError(f"{_where(agent, path)} must be an integer in [{start}, {start + n}), got {action!r}")
            value = int(number)
        if not start <= value < start + n:
            raise ValueError(f"{_where(agent, path)} is {value}, outside Discrete({n}) = [{start}, {start + n})")
        return value

    return check


def _box_checker(space: spaces.Box, integer: bool = False):
    shape = space.shape
    low32, high32 = space.low.ravel(), space.high.ravel()
    # The bounds as Python floats equal to the space's float32 values: a float64 value inside
    # them is inside after the cast to float32, so most actions pass the fast test.
    low, high = low32.astype(float).tolist(), high32.astype(float).tolist()
    dtype = space.dtype

    def check(agent: str, path: str, action: Any) -> np.ndarray:
        try:
            raw = np.asarray(action)
        except (TypeError, ValueError):
            raise TypeError(f"{_where(agent, path)} must be numeric with shape {shape}, got {action!r}") from None
        if raw.dtype.kind not in "biuf":
            raise TypeError(f"{_where(agent, path)} must be real numbers with shape {shape}, got {action!r}")
        array = raw.astype(np.float64, copy=True)
        if array.shape != shape:
            raise ValueError(f"{_where(agent, path)} has shape {array.shape}, expected {shape} (space {space})")
        values = array.ravel().tolist()
        # One pass: NaN fails every comparison, so in-bounds implies finite.
        inside = all(lo <= v <= hi for v, lo, hi in zip(values, low, high))
        if not inside:
            if not all(np.isfinite(values)):
                raise ValueError(f"{_where(agent, path)} contains NaN or infinite values: {values}")
            cast = array.ravel().astype(dtype)
            if not (np.all(cast >= low32) and np.all(cast <= high32)):
                raise ValueError(f"{_where(agent, path)} is {values}, outside the space bounds low={low} high={high}")
        if integer:
            if not all(float(v).is_integer() for v in values):
                raise ValueError(f"{_where(agent, path)} must hold integers, got {values}")
            return array.astype(np.int64)
        return array

    return check


def _dict_checker(space: spaces.Dict):
    children = {key: _checker(sub) for key, sub in space.spaces.items()}

    def check(agent: str, path: str, action: Any) -> dict[str, Any]:
        if not isinstance(action, Mapping):
            raise TypeError(f"{_where(agent, path)} must be a dict with keys {list(children)}, got {type(action).__name__}")
        missing = [k for k in children if k not in action]
        extra = [k for k in action if k not in children]
        if missing or extra:
            raise ValueError(f"{_where(agent, path)} has keys {list(action)}; expected exactly {list(children)}")
        return {key: child(agent, f"{path}.{key}" if path else repr(key), action[key]) for key, child in children.items()}

    return check


def _tuple_checker(space: spaces.Tuple):
    children = [_checker(sub) for sub in space.spaces]

    def check(agent: str, path: str, action: Any) -> tuple:
        if not isinstance(action, (tuple, list)) or len(action) != len(children):
            raise ValueError(f"{_where(agent, path)} must be a tuple of {len(children)} parts, got {action!r}")
        return tuple(child(agent, f"{path}[{i}]", part) for i, (child, part) in enumerate(zip(children, action)))

    return check
