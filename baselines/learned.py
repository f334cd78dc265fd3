"""Learned policies: one policy-name scheme per engine and one sidecar format for both.

Schemes (``--policy`` of ``baselines.evaluate``, :func:`baselines.registry.make_policy`):

* ``sb3:PATH``: a saved Stable-Baselines3 model (``PATH`` or ``PATH.zip``, or the name of a
  shipped agent; :class:`baselines.rl.sb3_policy.SB3Policy`); its sidecar is ``<model>.json``;
* ``rllib:PATH``: an RLlib checkpoint directory written by ``python -m baselines.rl.rllib``
  (:class:`baselines.rl.rllib.RLlibPolicy`); its sidecar is ``PATH/teamgym.json``.

The sidecar (format 1) is one JSON object. The fields every reader relies on:

* ``format``: ``1``;
* ``engine``: ``"sb3"`` or ``"rllib"``;
* ``env``: the env id the policy was trained on;
* ``overrides``: the config settings the training was given, as strings (``{"max_cycles": "50"}``):
  what ``baselines.evaluate`` applies when it evaluates on that env;
* ``config``: the resolved env config of training (every field; for reading, not applied);
* ``algo``: the algorithm (``"ppo"``, ``"maskable_ppo"``, ...);
* ``seed``: the training seed.

Optional, for an agent shipped as the median of several training seeds (``python -m
baselines.rl.seeds DIR --ship NAME``): ``seeds``, an object with the training seeds (``seeds``),
the one shipped (``median_seed``), the held-out seeds evaluated, each seed's success with its
Wilson interval and the figures across seeds (IQM and mean with bootstrap intervals); files
without it read as before.

Each engine adds its own training record beside them (SB3: ``timesteps``, ``hyperparameters``,
``bc``, ``eval``, ``best_eval``, ``critic``, ``agent_id``, ``independent``, and ``obs_features``
(``{"agent_id": bool, "team_state": bool}`` or ``null``: the parts appended to each robot's
observation, which ``sb3:PATH`` evaluation rebuilds, :mod:`baselines.rl.agent_features`), ...;
RLlib: ``module_id``, ``iterations``, ``training``, ``model``, ``history``, ``eval``, ...).
Files written before format 1 still load
(:func:`read_sidecar`): they have no ``format`` or ``engine`` (taken from where the file is), and
an RLlib ``teamgym.json`` then held the given settings in ``config`` (read as ``overrides``;
its resolved config is unknown). A field of the wrong type is a ``ValueError`` of one line
naming the file and the field. Writers write format 1 (:func:`write_sidecar`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = [
    "SCHEMES",
    "SIDECAR_FORMAT",
    "check_sidecar",
    "is_learned",
    "policy_sidecar",
    "read_sidecar",
    "read_sidecar_file",
    "sidecar_path",
    "split_scheme",
    "write_sidecar",
]

#: The policy-name schemes of learned policies: scheme -> what ``PATH`` names.
SCHEMES: dict[str, str] = {"sb3": "a model path or shipped agent", "rllib": "an RLlib checkpoint directory"}
#: The sidecar format :func:`write_sidecar` writes (and the newest :func:`read_sidecar` reads).
SIDECAR_FORMAT = 1
#: The file name of an RLlib checkpoint's sidecar, inside the checkpoint directory.
RLLIB_SIDECAR = "teamgym.json"


def split_scheme(name: str) -> tuple[str, str] | None:
    """``(scheme, PATH)`` of a learned-policy name (``"sb3:m.zip"`` -> ``("sb3", "m.zip")``), else ``None``."""
    scheme, sep, rest = name.partition(":")
    return (scheme, rest) if sep and scheme in SCHEMES else None


def is_learned(name: str) -> bool:
    """Whether ``name`` names a learned policy (``sb3:PATH`` or ``rllib:PATH``)."""
    return split_scheme(name) is not None


def sidecar_path(engine: str, path: str | Path) -> Path:
    """Where the sidecar of the ``engine`` policy at ``path`` is (the file need not exist).

    ``FileNotFoundError`` for an ``sb3`` model that does not exist (see :func:`~baselines.rl.sb3_policy.resolve_model`).
    """
    if engine == "sb3":
        from baselines.rl.sb3_policy import resolve_model

        return resolve_model(path).with_suffix(".json")
    if engine == "rllib":
        return Path(path) / RLLIB_SIDECAR
    raise ValueError(f"unknown engine {engine!r}; choose one of {sorted(SCHEMES)}")


def _field_error(path: Path, field: str, expected: str, value: Any) -> ValueError:
    return ValueError(f"the model's sidecar {str(path)!r}: field {field!r} must be {expected}, got {value!r}")


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _check_seeds_field(record: Any, path: Path) -> None:
    """The optional ``seeds`` field: an object with a non-empty ``seeds`` list and a ``median_seed`` among them."""
    if not isinstance(record, dict):
        raise _field_error(path, "seeds", "an object (the record across training seeds)", record)
    seeds = record.get("seeds")
    if not (isinstance(seeds, list) and seeds and all(_is_int(s) for s in seeds)):
        raise _field_error(path, "seeds.seeds", "a non-empty list of integers", seeds)
    median = record.get("median_seed")
    if not (_is_int(median) and median in seeds):
        raise _field_error(path, "seeds.median_seed", "one of seeds.seeds", median)


def check_sidecar(data: Any, engine: str, path: str | Path) -> dict[str, Any]:
    """``data`` (a parsed sidecar of ``engine`` at ``path``) in format 1, or ``ValueError`` naming the file and field.

    Fills ``format`` and ``engine`` of a file written before format 1 and moves an old RLlib
    sidecar's ``config`` (its given settings) to ``overrides``; every other field is kept.
    """
    path = Path(path)
    if not isinstance(data, dict):
        raise ValueError(f"the model's sidecar {str(path)!r} is not a JSON object")
    data = dict(data)
    version = data.get("format")
    if version is None:
        if engine == "rllib" and "overrides" not in data and isinstance(data.get("config"), dict):
            data["overrides"] = data.pop("config")
    elif version != SIDECAR_FORMAT or isinstance(version, bool):
        raise _field_error(path, "format", f"{SIDECAR_FORMAT} (the sidecar format this teamgym reads)", version)
    if data.setdefault("engine", engine) != engine:
        raise _field_error(path, "engine", f"{engine!r} (the file is beside an {engine} policy)", data["engine"])
    for field in ("env", "algo"):
        value = data.get(field)
        if value is not None and not (isinstance(value, str) and value.strip()):
            raise _field_error(path, field, "a non-empty string", value)
    for field in ("overrides", "config"):
        value = data.get(field)
        if value is not None and not (isinstance(value, dict) and all(isinstance(k, str) for k in value)):
            raise _field_error(path, field, "an object with string keys", value)
    if data.get("seeds") is not None:
        _check_seeds_field(data["seeds"], path)
    overrides = data.get("overrides")
    if overrides is not None:
        bad = {k: v for k, v in overrides.items() if not isinstance(v, (str, int, float, bool))}
        if bad:
            key = next(iter(bad))
            raise _field_error(path, f"overrides.{key}", "a string (a setting as on the command line)", bad[key])
        data["overrides"] = {k: str(v) for k, v in overrides.items()}
    return {"format": SIDECAR_FORMAT, **data}


def read_sidecar_file(path: str | Path, engine: str) -> dict[str, Any] | None:
    """The sidecar file ``path`` of an ``engine`` policy in format 1 (:func:`check_sidecar`), or ``None`` if it does not exist.

    ``ValueError`` naming the file when it cannot be read, is not JSON or has a field of the wrong type.
    """
    path = Path(path)
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ValueError(f"cannot read the model's sidecar {str(path)!r}: {' '.join(str(error).split())}") from None
    return check_sidecar(data, engine, path)


def read_sidecar(engine: str, path: str | Path) -> dict[str, Any] | None:
    """The sidecar of the ``engine`` policy at ``path`` (:func:`sidecar_path`, :func:`read_sidecar_file`), or ``None``.

    ``None`` when there is no sidecar, and when an ``sb3`` model does not exist.
    """
    try:
        where = sidecar_path(engine, path)
    except FileNotFoundError:
        return None
    return read_sidecar_file(where, engine)


def policy_sidecar(name: str) -> tuple[dict[str, Any], Path] | None:
    """The sidecar of learned policy ``name`` (``sb3:PATH``, ``rllib:PATH``) and its path, or ``None``."""
    split = split_scheme(name)
    if split is None:
        return None
    data = read_sidecar(*split)
    return None if data is None else (data, sidecar_path(*split))


def write_sidecar(path: str | Path, engine: str, data: Mapping[str, Any]) -> Path:
    """Write ``data`` as the format-1 sidecar file ``path`` of an ``engine`` policy (checked first); returns ``path``."""
    from baselines.summary import write_json

    checked = check_sidecar({**data, "format": SIDECAR_FORMAT, "engine": engine}, engine, path)
    head = {key: checked.pop(key) for key in ("format", "engine", "env", "overrides", "config", "algo", "seed") if key in checked}
    return write_json(path, {**head, **checked}, default=repr)
