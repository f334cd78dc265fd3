"""Foraging-v0 baselines (paper 002): DMAPS with and without communication, and a random walk.

* ``dmaps`` (:mod:`baselines.foraging.dmaps`): per-robot probabilistic world model
  (:mod:`teamgym.envs.foraging.world_model`), shortest-distance target allocation
  (:mod:`baselines.foraging.allocation`) and MAPS potential fields
  (:mod:`baselines.foraging.potential`);
* ``dmaps-nocomm``: the same without the received packets;
* ``random-walk`` (:mod:`baselines.foraging.random_walk`): random admissible cells, a seen
  target approached and held.
"""
