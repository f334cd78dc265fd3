"""Baseline policies from the papers, the SB3 adapter and the evaluation CLI.

``make_policy(name, env)`` builds a policy by name: ``goto`` (go-to-goal), ``random``,
or ``sb3:PATH`` (a saved Stable-Baselines3 model, parameter-shared across robots).
"""

from baselines.policy import Policy, RandomPolicy
from baselines.registry import make_policy, policies, register_policy

__all__ = ["Policy", "RandomPolicy", "make_policy", "policies", "register_policy"]
