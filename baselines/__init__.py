"""Baseline policies from the papers, the SB3 adapter and the evaluation CLI.

``make_policy(name, env)`` builds a policy by name (``policies()`` lists them):

* any env: ``random`` (uniform random actions); ``sb3:PATH`` (a saved Stable-Baselines3
  model, parameter-shared across robots; :mod:`baselines.rl`);
* Navigation-v0 (paper 001, :mod:`baselines.navigation`): ``goto`` (turn to the goal and
  drive), ``nash`` (one non-cooperative game per step with the fair arbiter; heading
  actions), ``nash-first`` (the first equilibrium, no arbiter);
* Exploration-v0 (paper 000, :mod:`baselines.exploration`, operator actions):
  ``nash-explore`` (one team game per planning stage), ``greedy`` (nearest unexplored
  sector), ``random-admissible`` (a random admissible operator);
* BoxPushing-v0 (paper 004, :mod:`baselines.box_pushing`): ``sbs`` (situated behaviour
  sets with a per-robot situation recognizer), ``sbs1`` (SBS-1 in every situation),
  ``sbs-oracle`` (diagnostic: other robots recognized from the simulator's state).

``run_episode(env, policy, seed, on_step=...)`` plays one episode (:mod:`baselines.episode`).
"""

from baselines.episode import EpisodeResult, Step, run_episode
from baselines.policy import Policy, RandomPolicy
from baselines.registry import make_policy, policies, register_policy

__all__ = ["EpisodeResult", "Policy", "RandomPolicy", "Step", "make_policy", "policies", "register_policy", "run_episode"]
