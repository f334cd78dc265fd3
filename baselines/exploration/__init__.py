"""Exploration-v0 baselines: paper 000's game-theoretic planner, greedy and random admissible operators."""
