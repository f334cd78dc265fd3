"""Policy names for ``--policy``: ``make_policy(name, env)``."""

from __future__ import annotations

import importlib
from typing import Any

from baselines.learned import split_scheme
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
    "bidir-astar-eager": ("baselines.rendezvous.protocol:RendezvousProtocol", {"planner": "bidir-astar", "execution": "eager"}),
    "centralized": ("baselines.rendezvous.centralized:CentralizedRendezvous", {}),
    "place-beacon": ("baselines.rendezvous.place_beacon:PlaceBeacon", {}),
    "dmaps": ("baselines.foraging.dmaps:DMAPS", {}),
    "dmaps-nocomm": ("baselines.foraging.dmaps:DMAPS", {"communication": False}),
    "random-walk": ("baselines.foraging.random_walk:RandomWalk", {}),
}


def register_policy(name: str, entry_point: str, **kwargs: Any) -> None:
    """Register a policy class (``"module:Class"``, built as ``Class(env, **kwargs)``) under ``name``."""
    _POLICIES[name] = (entry_point, kwargs)


def policies() -> list[str]:
    """Registered policy names (plus the learned policies ``sb3:PATH`` and ``rllib:PATH``, :mod:`baselines.learned`)."""
    return sorted(_POLICIES)


#: learned-policy scheme -> "module:Class" of its policy (built with ``Class.load(PATH, env, **kwargs)``)
_LEARNED: dict[str, str] = {"sb3": "baselines.rl.sb3_policy:SB3Policy", "rllib": "baselines.rl.rllib:RLlibPolicy"}


def _class(entry_point: str) -> Any:
    module_name, _, class_name = entry_point.partition(":")
    return getattr(importlib.import_module(module_name), class_name)


def policy_class(name: str) -> type[Policy]:
    """The class behind policy ``name`` (``sb3:PATH`` gives :class:`SB3Policy`, ``rllib:PATH`` :class:`RLlibPolicy`)."""
    split = split_scheme(name)
    if split is not None:
        return _class(_LEARNED[split[0]])
    if name not in _POLICIES:
        raise KeyError(f"unknown policy {name!r}; available: {policies()}, sb3:PATH or rllib:PATH")
    return _class(_POLICIES[name][0])


def required_config(name: str) -> dict[str, Any]:
    """Env config a policy needs (e.g. ``action_type="heading"`` for ``nash``); explicit settings override it."""
    return dict(getattr(policy_class(name), "required_config", {}))


def make_policy(name: str, env: TeamEnv, **kwargs: Any) -> Policy:
    """Build policy ``name`` for ``env``; ``sb3:PATH`` loads a saved Stable-Baselines3 model, ``rllib:PATH`` an RLlib checkpoint.

    Raises ``ValueError`` naming the policy, the env and what is missing when the policy
    does not fit the env (:meth:`Policy.check_env`; a learned policy's spaces must match the env's).
    """
    cls = policy_class(name)
    cls.check_env(env, name)
    split = split_scheme(name)
    if split is not None:
        return cls.load(split[1], env, **kwargs)
    return cls(env, **{**_POLICIES[name][1], **kwargs})
