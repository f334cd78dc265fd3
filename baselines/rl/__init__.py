"""Reinforcement-learning tools: the Stable-Baselines3 adapter, saved-model policies and training."""
