"""Baseline policies from the papers, the SB3 adapter and the evaluation CLI.

``make_policy(name, env)`` builds a policy by name: ``goto`` (go-to-goal), ``random``,
or ``sb3:PATH`` (a saved Stable-Baselines3 model, parameter-shared across robots).
``run_episode(env, policy, seed, on_step=...)`` plays one episode (:mod:`baselines.episode`).
"""

from baselines.episode import EpisodeResult, Step, run_episode
from baselines.policy import Policy, RandomPolicy
from baselines.registry import make_policy, policies, register_policy

__all__ = ["EpisodeResult", "Policy", "RandomPolicy", "Step", "make_policy", "policies", "register_policy", "run_episode"]
