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


def _external(index: int) -> Any:
    """Stands for ``external[index]`` in a pickle; :func:`loads` resolves it."""
    raise pickle.UnpicklingError("a snapshot refers to objects it does not hold: load it with teamgym.sim.snapshot.loads")


class _Pickler(pickle.Pickler):
    def __init__(self, file: io.BytesIO, external: Sequence[Any]) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._index = {id(obj): i for i, obj in enumerate(external)}

    def reducer_override(self, obj: Any) -> Any:
        index = self._index.get(id(obj))
        if index is not None:
            return _external, (index,)
        if type(obj) is not np.ndarray or not isinstance(obj.base, np.ndarray) or obj.dtype.hasobject:
            return NotImplemented
        root = obj.base
        while isinstance(root.base, np.ndarray):
            root = root.base
        if not (root.flags.c_contiguous or root.flags.f_contiguous):
            return NotImplemented
        offset = obj.__array_interface__["data"][0] - root.__array_interface__["data"][0]
        return _view, (root, obj.dtype, obj.shape, obj.strides, offset, bool(obj.flags.writeable))


class _Unpickler(pickle.Unpickler):
    def __init__(self, file: io.BytesIO, external: Sequence[Any]) -> None:
        super().__init__(file)
        self._external = external

    def find_class(self, module: str, name: str) -> Any:
        if module == __name__ and name == "_external":
            return self._resolve
        return super().find_class(module, name)

    def _resolve(self, index: int) -> Any:
        if not 0 <= index < len(self._external):
            raise pickle.UnpicklingError(
                f"the snapshot refers to external object {index}, but loads() was given {len(self._external)} external object(s)"
            )
        return self._external[index]


def dumps(obj: Any, external: Sequence[Any] = ()) -> bytes:
    """Pickle ``obj``, keeping numpy views and writing references to ``external[i]`` as ``i``."""
    buffer = io.BytesIO()
    _Pickler(buffer, external).dump(obj)
    return buffer.getvalue()


def loads(data: bytes, external: Sequence[Any] = ()) -> Any:
    """Unpickle what :func:`dumps` wrote, with ``external[i]`` where it referred to the ``i``-th external object."""
    return _Unpickler(io.BytesIO(data), external).load()
