"""Versioned environment ids and ``make``."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from teamgym.envs.base import TeamEnv

if TYPE_CHECKING:
    from teamgym.envs.batch import TeamBatch

#: env id -> "module:Class"
_REGISTRY: dict[str, str] = {}


def register(env_id: str, entry_point: str) -> None:
    """Register ``env_id`` (``Name-vN``) for the class at ``entry_point`` (``"module:Class"``)."""
    name, _, version = env_id.rpartition("-v")
    if not name or not version.isdigit():
        raise ValueError(f"env id {env_id!r} must look like 'Name-vN'")
    if env_id in _REGISTRY and _REGISTRY[env_id] != entry_point:
        raise ValueError(f"env id {env_id!r} is already registered to {_REGISTRY[env_id]}")
    _REGISTRY[env_id] = entry_point


def envs() -> list[str]:
    """The registered env ids, sorted."""
    return sorted(_REGISTRY)


def env_class(env_id: str) -> type[TeamEnv]:
    if not isinstance(env_id, str) or env_id not in _REGISTRY:
        hint = ""
        if isinstance(env_id, str):
            same_name = [e for e in _REGISTRY if e.rpartition("-v")[0] == env_id.rpartition("-v")[0]]
            if same_name:
                hint = f" (versions available: {sorted(same_name)})"
        raise KeyError(f"unknown env id {env_id!r}{hint}; registered ids are {envs()}")
    module_name, _, class_name = _REGISTRY[env_id].partition(":")
    return getattr(importlib.import_module(module_name), class_name)


def make(env_id: str, render_mode: str | None = None, **config: Any) -> TeamEnv:
    """Create the parallel env ``env_id`` with config overrides, e.g. ``make("Navigation-v0", n_robots=5)``."""
    return env_class(env_id)(render_mode=render_mode, **config)


def make_batch(
    env_id: str,
    n_copies: int,
    *,
    auto_reset: bool = False,
    render_mode: str | None = None,
    trails: bool = False,
    **config: Any,
) -> TeamBatch:
    """``n_copies`` copies of ``env_id`` stepped together with arrays, e.g. ``make_batch("Foraging-v0", 16)``.

    Every id, action type and observation format has one (:class:`~teamgym.envs.batch.TeamBatch`);
    ``auto_reset``, ``render_mode`` and ``trails`` are the batch's options, the rest the env's config.
    """
    from teamgym.envs.batch import TeamBatch

    return TeamBatch(env_class(env_id), n_copies, config, auto_reset=auto_reset, render_mode=render_mode, trails=trails)


def make_aec(env_id: str, render_mode: str | None = None, **config: Any):
    """The AEC form of ``make(...)`` (PettingZoo's ``parallel_to_aec``)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(make(env_id, render_mode=render_mode, **config))


register("Navigation-v0", "teamgym.envs.navigation:Navigation")
register("BoxPushing-v0", "teamgym.envs.box_pushing:BoxPushing")
register("BoxPushing-v1", "teamgym.envs.box_pushing:BoxPushingV1")
register("Exploration-v0", "teamgym.envs.exploration:Exploration")
register("Rendezvous-v0", "teamgym.envs.rendezvous:Rendezvous")
register("Foraging-v0", "teamgym.envs.foraging:Foraging")
