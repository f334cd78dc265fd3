"""SuperSuit + Stable-Baselines3 (``baselines.rl.supersuit_env``): PPO and MaskablePPO on SuperSuit vector envs.

PPO on the flat format of every env id whose default action type has no masks, MaskablePPO on
the masked format of every action type with masks, and a robot joining mid-episode. Marked
``supersuit``: run in their own venv by ``bash scripts/run_tests_integrations.sh supersuit``;
skipped where supersuit is not installed.
"""

import os

import pytest

if os.environ.get("TEAMGYM_STACK") != "supersuit":
    pytest.importorskip("supersuit", reason="needs the supersuit extra: bash scripts/run_tests_integrations.sh supersuit")

import numpy as np
import torch
from sb3_contrib import MaskablePPO
from stable_baselines3 import PPO

import teamgym
from baselines.rl.supersuit_env import supersuit_vec_env

pytestmark = pytest.mark.supersuit
torch.set_num_threads(1)  # tiny networks: more threads only contend on the shared machine

FLAT = [("Navigation-v0", {}), ("Exploration-v0", {}), ("BoxPushing-v0", {}), ("BoxPushing-v1", {})]
MASKED = [
    ("Rendezvous-v0", {"max_cycles": 120}),
    ("Exploration-v0", {"action_type": "operator"}),
    ("Foraging-v0", {"max_cycles": 12}),
]


def _learn(algorithm, venv, steps: int):
    model = algorithm("MlpPolicy", venv, n_steps=steps // venv.num_envs, batch_size=32, n_epochs=1, seed=0, device="cpu")
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(total_timesteps=steps)
    assert model.num_timesteps == steps
    assert any(not torch.equal(a, b) for a, b in zip(model.policy.parameters(), before)), "the policy did not change"
    return model


@pytest.mark.parametrize(("env_id", "config"), FLAT, ids=[c[0] for c in FLAT])
def test_ppo_learns_on_the_flat_format(env_id, config):
    venv = supersuit_vec_env(env_id, {"max_cycles": 30, **config}, n_copies=2)
    assert venv.num_envs == 2 * len(teamgym.make(env_id).possible_agents)
    _learn(PPO, venv, 64 * venv.num_envs)


@pytest.mark.parametrize(("env_id", "config"), MASKED, ids=[c[0] for c in MASKED])
def test_maskable_ppo_learns_on_the_masked_format(env_id, config):
    venv = supersuit_vec_env(env_id, {"max_cycles": 30, **config, "obs_format": "masked"}, n_copies=2)
    observations = venv.reset()
    masks = venv.action_masks()
    assert observations.shape == (venv.num_envs, *venv.observation_space.shape) and masks.dtype == bool
    assert np.array_equal(np.stack(venv.env_method("action_masks")), masks)
    # teamgym raises on an inadmissible action: finished learning shows MaskablePPO used the masks.
    _learn(MaskablePPO, venv, 32 * venv.num_envs)


def test_slots_are_seeded_apart_and_episode_ends_are_flagged():
    venv = supersuit_vec_env("Navigation-v0", {"max_cycles": 5}, n_copies=2)
    venv.seed(7)
    first = venv.reset()
    assert not np.array_equal(first[:3], first[3:]), "the two copies should start from different scenes"
    venv.seed(7)
    assert np.array_equal(venv.reset(), first)
    for _ in range(5):
        _, rewards, dones, infos = venv.step(np.zeros((venv.num_envs, 2), np.float32))
    assert dones.all() and all(info["TimeLimit.truncated"] for info in infos)
    assert all("terminal_observation" in info for info in infos)


def test_a_joining_robot_has_a_slot_from_the_start():
    config = {"n_spare_robots": 1, "events": ((20, "add_robot"),), "max_cycles": 30}
    venv = supersuit_vec_env("BoxPushing-v0", config, n_copies=1)
    observations = venv.reset()
    present = []
    for _ in range(25):
        present.append(observations[:, -1].copy())
        observations, rewards, dones, _ = venv.step(np.zeros(venv.num_envs, dtype=np.int64))
        assert not dones.any()
    present = np.array(present)  # (steps, slots)
    assert (present[:, :2] == 1).all()
    assert np.array_equal(present[:, 2], (np.arange(25) >= 20).astype(np.float32))
    _learn(PPO, supersuit_vec_env("BoxPushing-v0", config, n_copies=1), 96)
