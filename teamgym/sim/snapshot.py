"""Plain pickles of live simulation state: numpy views stay views, and chosen objects are referred to.

:func:`dumps` pickles an object graph as :mod:`pickle` does, with two differences:

* a numpy array that is a view of another array is pickled as a view of that array's
  root (the array owning the memory), so both come back sharing memory (plain pickle copies
  each view on its own, and a write through one would no longer show through the other);
* the objects in ``external`` are not pickled: a reference to ``external[i]`` is written as
  the index ``i``, and :func:`loads` puts ``external[i]`` of the list it is given in its
  place (the owner of the state, e.g. the env, or objects both sides already have);
* objects that pickle by their attributes (no ``__reduce__`` or ``__setstate__`` of their
  own) come back with their attributes set one by one rather than written into their
  ``__dict__``: CPython 3.11 reads the attributes of an object whose ``__dict__`` was
  written to about 2.5 times slower, and an unpickled env would step slower for the rest of
  its life.

Everything else (pymunk spaces, bodies, shapes and constraints included) pickles by its
own ``__reduce__``/``__getstate__``.
"""

from __future__ import annotations

import contextvars
import copyreg
import io
import pickle
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["dumps", "loads"]


def _view(root: np.ndarray, dtype: np.dtype, shape: tuple, strides: tuple, offset: int, writeable: bool) -> np.ndarray:
    view = np.ndarray(shape, dtype, buffer=root, offset=offset, strides=strides)
    if not writeable:
        view.flags.writeable = False
    return view


_LOADING: contextvars.ContextVar[Sequence[Any] | None] = contextvars.ContextVar("teamgym_snapshot_external", default=None)


def _external(index: int) -> Any:
    """Stands for ``external[index]`` in a pickle: the object :func:`loads` was given in that place."""
    external = _LOADING.get()
    if external is None:
        raise pickle.UnpicklingError("a snapshot refers to objects it does not hold: load it with teamgym.sim.snapshot.loads")
    if not 0 <= index < len(external):
        raise pickle.UnpicklingError(
            f"the snapshot refers to external object {index}, but loads() was given {len(external)} external object(s)"
        )
    return external[index]


def _set_attributes(obj: Any, state: dict[str, Any] | None) -> None:
    """Set the attributes of a new object one by one (see the module docstring)."""
    for name, value in (state or {}).items():
        object.__setattr__(obj, name, value)


_BY_ATTRIBUTES: dict[type, bool] = {}


def _pickles_by_attributes(cls: type) -> bool:
    """Whether instances of ``cls`` pickle as their ``__getstate__()`` dict set on a bare ``cls.__new__(cls)``."""
    known = _BY_ATTRIBUTES.get(cls)
    if known is None:
        known = _BY_ATTRIBUTES[cls] = (
            cls.__reduce_ex__ is object.__reduce_ex__
            and cls.__reduce__ is object.__reduce__
            and getattr(cls, "__setstate__", None) is None
            and cls.__new__ is object.__new__
            and not any("__slots__" in vars(c) for c in cls.__mro__[:-1])
        )
    return known


class _Pickler(pickle.Pickler):
    def __init__(self, file: io.BytesIO, external: Sequence[Any]) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._index = {id(obj): i for i, obj in enumerate(external)}

    def reducer_override(self, obj: Any, _ndarray: type = np.ndarray) -> Any:
        if type(obj) is not _ndarray:
            index = self._index.get(id(obj))
            if index is not None:
                return _external, (index,)
            cls = type(obj)
            if not isinstance(obj, type) and _pickles_by_attributes(cls) and hasattr(obj, "__dict__"):
                state = obj.__getstate__()
                if state is None or isinstance(state, dict):
                    return copyreg.__newobj__, (cls,), state, None, None, _set_attributes
            return NotImplemented
        if not isinstance(obj.base, _ndarray) or obj.dtype.hasobject:
            return NotImplemented
        root = obj.base
        while isinstance(root.base, np.ndarray):
            root = root.base
        if not (root.flags.c_contiguous or root.flags.f_contiguous):
            return NotImplemented
        offset = obj.__array_interface__["data"][0] - root.__array_interface__["data"][0]
        return _view, (root, obj.dtype, obj.shape, obj.strides, offset, bool(obj.flags.writeable))


def dumps(obj: Any, external: Sequence[Any] = ()) -> bytes:
    """Pickle ``obj``, keeping numpy views and writing references to ``external[i]`` as ``i``."""
    buffer = io.BytesIO()
    _Pickler(buffer, external).dump(obj)
    return buffer.getvalue()


def loads(data: bytes, external: Sequence[Any] = ()) -> Any:
    """Unpickle what :func:`dumps` wrote, with ``external[i]`` where it referred to the ``i``-th external object."""
    token = _LOADING.set(external)
    try:
        return pickle.loads(data)
    finally:
        _LOADING.reset(token)
