"""Policy names for ``--policy``: ``make_policy(name, env)``."""

from __future__ import annotations

import importlib
from typing import Any

from baselines.policy import Policy
from teamgym.envs.base import TeamEnv

#: name -> ("module:Class", constructor keyword arguments)
_POLICIES: dict[str, tuple[str, dict[str, Any]]] = {
    "goto": ("baselines.navigation.goto_goal:GoToGoal", {}),
    "random": ("baselines.policy:RandomPolicy", {}),
    "nash": ("baselines.navigation.nash:NashNavigation", {}),
    "nash-first": ("baselines.navigation.nash:NashNavigation", {"selection": "first"}),
    "sbs": ("baselines.box_pushing.sbs:SituatedBehaviourSets", {}),
    "sbs1": ("baselines.box_pushing.sbs:SituatedBehaviourSets", {"fixed_sbs": 1}),
    "sbs-oracle": ("baselines.box_pushing.sbs:SituatedBehaviourSets", {"recognition": "oracle"}),
    "sbs-literal": ("baselines.box_pushing.sbs:SituatedBehaviourSets", {"reading": "literal"}),
    "cooperative-push": ("baselines.box_pushing.cooperative:CooperativePush", {}),
    "nash-explore": ("baselines.exploration.nash_explore:NashExplore", {}),
    "greedy": ("baselines.exploration.policies:GreedyExplore", {}),
    "random-admissible": ("baselines.exploration.policies:RandomAdmissible", {}),
    "bidir-astar": ("baselines.rendezvous.protocol:RendezvousProtocol", {"planner": "bidir-astar"}),
    "bidir-astar-opt": ("baselines.rendezvous.protocol:RendezvousProtocol", {"planner": "bidir-astar-opt"}),
    "astar-protocol": ("baselines.rendezvous.protocol:RendezvousProtocol", {"planner": "astar"}),
    "centralized": ("baselines.rendezvous.centralized:CentralizedRendezvous", {}),
    "dmaps": ("baselines.foraging.dmaps:DMAPS", {}),
    "dmaps-nocomm": ("baselines.foraging.dmaps:DMAPS", {"communication": False}),
    "random-walk": ("baselines.foraging.random_walk:RandomWalk", {}),
}


def register_policy(name: str, entry_point: str, **kwargs: Any) -> None:
    """Register a policy class (``"module:Class"``, built as ``Class(env, **kwargs)``) under ``name``."""
    _POLICIES[name] = (entry_point, kwargs)


def policies() -> list[str]:
    """Registered policy names (plus ``sb3:PATH`` for saved SB3 models)."""
    return sorted(_POLICIES)


def policy_class(name: str) -> type[Policy]:
    """The class behind policy ``name`` (``sb3:PATH`` gives :class:`SB3Policy`)."""
    if name.startswith("sb3:"):
        from baselines.rl.sb3_policy import SB3Policy

        return SB3Policy
    if name not in _POLICIES:
        raise KeyError(f"unknown policy {name!r}; available: {policies()} or sb3:PATH")
    module_name, _, class_name = _POLICIES[name][0].partition(":")
    return getattr(importlib.import_module(module_name), class_name)


def required_config(name: str) -> dict[str, Any]:
    """Env config a policy needs (e.g. ``action_type="heading"`` for ``nash``); explicit settings override it."""
    return dict(getattr(policy_class(name), "required_config", {}))


def make_policy(name: str, env: TeamEnv, **kwargs: Any) -> Policy:
    """Build policy ``name`` for ``env``; ``sb3:PATH`` loads a saved Stable-Baselines3 model.

    Raises ``ValueError`` naming the policy, the env and what is missing when the policy
    does not fit the env (:meth:`Policy.check_env`; an SB3 model's spaces must match the env's).
    """
    cls = policy_class(name)
    cls.check_env(env, name)
    if name.startswith("sb3:"):
        return cls.load(name[4:], env, **kwargs)
    return cls(env, **{**_POLICIES[name][1], **kwargs})
