"""Policy names for ``--policy``: ``make_policy(name, env)``."""

from __future__ import annotations

import importlib
from typing import Any

from baselines.policy import Policy
from teamgym.envs.base import TeamEnv

#: name -> "module:Class"
_POLICIES: dict[str, str] = {
    "goto": "baselines.goto_goal:GoToGoal",
    "random": "baselines.policy:RandomPolicy",
}


def register_policy(name: str, entry_point: str) -> None:
    """Register a policy class (``"module:Class"``, constructor ``Class(env, **kwargs)``) under ``name``."""
    _POLICIES[name] = entry_point


def policies() -> list[str]:
    """Registered policy names (plus ``sb3:PATH`` for saved SB3 models)."""
    return sorted(_POLICIES)


def make_policy(name: str, env: TeamEnv, **kwargs: Any) -> Policy:
    """Build policy ``name`` for ``env``; ``sb3:PATH`` loads a saved Stable-Baselines3 model."""
    if name.startswith("sb3:"):
        from baselines.sb3_policy import SB3Policy

        return SB3Policy.load(name[4:], env, **kwargs)
    if name not in _POLICIES:
        raise KeyError(f"unknown policy {name!r}; available: {policies()} or sb3:PATH")
    module_name, _, class_name = _POLICIES[name].partition(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    return cls(env, **kwargs)
