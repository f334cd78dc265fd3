"""Plain pickles of live simulation state: numpy views stay views, and chosen objects are referred to.

:func:`dumps` pickles an object graph as :mod:`pickle` does, with two differences:

* a numpy array that is a view of another array is pickled as a view of that array's
  root (the array owning the memory), so both come back sharing memory (plain pickle copies
  each view on its own, and a write through one would no longer show through the other);
* the objects in ``external`` are not pickled: a reference to ``external[i]`` is written as
  the index ``i``, and :func:`loads` puts ``external[i]`` of the list it is given in its
  place (the owner of the state, e.g. the env, or objects both sides already have).

Everything else (pymunk spaces, bodies, shapes and constraints included) pickles by its
own ``__reduce__``/``__getstate__``.
"""

from __future__ import annotations

import contextvars
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


class _Pickler(pickle.Pickler):
    def __init__(self, file: io.BytesIO, external: Sequence[Any]) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._index = {id(obj): i for i, obj in enumerate(external)}

    def reducer_override(self, obj: Any, _ndarray: type = np.ndarray) -> Any:
        if type(obj) is not _ndarray:
            index = self._index.get(id(obj))
            return NotImplemented if index is None else (_external, (index,))
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
