"""Baseline policies from the papers, the SB3 adapter and the evaluation CLI.

``make_policy(name, env)`` builds a policy by name (``policies()`` lists them):

* any env: ``random`` (uniform random actions); ``sb3:PATH`` (a saved Stable-Baselines3
  model, parameter-shared across robots; :mod:`baselines.rl`); ``rllib:PATH`` (an RLlib
  checkpoint of ``python -m baselines.rl.rllib``; :mod:`baselines.learned`);
* Navigation-v0 (paper 001, :mod:`baselines.navigation`): ``goto`` (turn to the goal and
  drive), ``nash`` (one non-cooperative game per step with the fair arbiter; heading
  actions), ``nash-first`` (the first equilibrium, no arbiter);
* Exploration-v0 (paper 000, :mod:`baselines.exploration`, operator actions):
  ``nash-explore`` (one team game per planning stage), ``greedy`` (nearest unexplored
  sector), ``random-admissible`` (a random admissible operator);
* BoxPushing-v0 (paper 004, :mod:`baselines.box_pushing`): ``sbs`` (situated behaviour
  sets with a per-robot situation recognizer), ``sbs1`` (SBS-1 in every situation),
  ``sbs-oracle`` (diagnostic: other robots recognized from the simulator's state),
  ``sbs-literal`` (footnote 1 and B-17–B-19 read literally, X-robot within 20 mm);
* Rendezvous-v0 (paper 003, :mod:`baselines.rendezvous`): ``bidir-astar``, ``bidir-astar-opt``,
  ``astar-protocol`` (the paper's protocol with three planners), ``centralized`` (reference);
* Foraging-v0 (paper 002, :mod:`baselines.foraging`, go-to-cell actions): ``dmaps`` (grid world
  model fused from shared perception tuples, MAPS potential field, shortest-distance
  allocation), ``dmaps-nocomm`` (communication ignored), ``random-walk``.

``run_episode(env, policy, seed, on_step=...)`` plays one episode (:mod:`baselines.episode`).
"""

from __future__ import annotations

import importlib
from typing import Any

# Names are imported on first use, so that ``python -m baselines.evaluate`` can limit numeric
# threads before numpy loads (importing this package imports nothing heavy).
_EXPORTS = {
    "EpisodeResult": "baselines.episode",
    "Step": "baselines.episode",
    "run_episode": "baselines.episode",
    "Policy": "baselines.policy",
    "RandomPolicy": "baselines.policy",
    "make_policy": "baselines.registry",
    "policies": "baselines.registry",
    "register_policy": "baselines.registry",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'baselines' has no attribute {name!r}")
