"""The SB3 adapter over an env's batch (``make_batch``) gives what it gives over the PettingZoo copies, on every env."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402


def goal_seeking(venv: TeamVecEnv, observations: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unit-scaled (v, ω) towards each slot's goal with noise, so robots arrive one by one and slots refill."""
    layout = venv.envs[0].layout
    goal = observations[:, layout.slices["goal_offset"]]
    error = np.arctan2(goal[:, 1], goal[:, 0]) - observations[:, 2]
    error = np.arctan2(np.sin(error), np.cos(error)) + rng.normal(0.0, 0.5, size=len(error))
    v = np.where(np.abs(error) < 0.6, 0.6, -0.8)
    return np.clip(np.stack([v, 0.8 * error], axis=1), -1, 1).astype(np.float32)


@pytest.mark.parametrize("n_envs", [1, 3])
def test_batched_and_pettingzoo_copies_agree(n_envs):
    config = {"n_robots": 3, "normalize_actions": True, "max_cycles": 120}
    make = lambda: teamgym.make("Navigation-v0", **config)  # noqa: E731
    batched, plain = TeamVecEnv(make, n_envs=n_envs), TeamVecEnv(make, n_envs=n_envs, batched=False)
    assert batched.batched and not plain.batched
    batched.seed(7)
    plain.seed(7)
    observations = batched.reset()
    assert np.array_equal(observations, plain.reset())
    rng = np.random.default_rng(0)
    dones_seen = 0
    for _ in range(300):
        actions = goal_seeking(batched, observations, rng)
        batched.step_async(actions)
        plain.step_async(actions)
        observations, rewards, dones, infos = batched.step_wait()
        plain_obs, plain_rewards, plain_dones, plain_infos = plain.step_wait()
        assert np.array_equal(observations, plain_obs)
        assert np.array_equal(rewards, plain_rewards) and np.array_equal(dones, plain_dones)
        for info, plain_info in zip(infos, plain_infos):
            for key in ("TimeLimit.truncated", "is_success", "padding"):
                assert info.get(key) == plain_info.get(key), key
            assert ("episode" in info) == ("episode" in plain_info)
            if "episode" in info:
                assert (info["episode"]["r"], info["episode"]["l"]) == (plain_info["episode"]["r"], plain_info["episode"]["l"])
                assert np.array_equal(info["terminal_observation"], plain_info["terminal_observation"])
                assert info["collisions"] == plain_info["collisions"]  # the finishing robot's metrics
        dones_seen += int(dones.sum())
    assert dones_seen > 3 * n_envs  # robots finished and slots were refilled
    assert len(batched.envs) == len(plain.envs) and batched.padding_share == plain.padding_share
    assert batched.padding_share > 0  # slots waited for a copy
    assert len(batched.envs) > n_envs or n_envs == 1  # with several copies, freed slots filled a new copy
    batched.seed(7)
    plain.seed(7)
    assert np.array_equal(batched.reset(), plain.reset())  # a reset drops the added copies in both
    assert len(batched.envs) == len(plain.envs) == n_envs


@pytest.mark.parametrize("env_id", teamgym.envs())
def test_every_env_steps_the_same_batched_and_one_by_one(env_id):
    """Random (admissible) actions through both paths: same observations, rewards, dones and finishing infos."""
    make = lambda: teamgym.make(env_id, max_cycles=12)  # noqa: E731
    batched, plain = TeamVecEnv(make, n_envs=2), TeamVecEnv(make, n_envs=2, batched=False)
    assert batched.batched and not plain.batched
    batched.seed(5)
    plain.seed(5)
    assert np.array_equal(batched.reset(), plain.reset())
    rng = np.random.default_rng(0)
    space = batched.action_space
    finished = 0
    for _ in range(30):
        if hasattr(space, "n"):
            masks = batched.action_masks()
            assert np.array_equal(masks, plain.action_masks())
            actions = np.array([rng.choice(np.flatnonzero(m)) for m in masks])
        else:
            actions = rng.uniform(space.low, space.high, size=(batched.num_envs, *space.shape)).astype(space.dtype)
        batched.step_async(actions)
        plain.step_async(actions)
        observations, rewards, dones, infos = batched.step_wait()
        plain_obs, plain_rewards, plain_dones, plain_infos = plain.step_wait()
        assert np.array_equal(observations, plain_obs) and np.array_equal(rewards, plain_rewards)
        assert np.array_equal(dones, plain_dones)
        for info, plain_info in zip(infos, plain_infos):
            assert ("episode" in info) == ("episode" in plain_info)
            assert info.get("is_success") == plain_info.get("is_success")
            if "episode" in info:
                assert info["episode"]["r"] == plain_info["episode"]["r"] and info["success"] == plain_info["success"]
                assert np.array_equal(info["terminal_observation"], plain_info["terminal_observation"])
        finished += int(dones.sum())
    assert finished > 0


def test_batched_refused_where_copies_cannot_be_one_batch():
    with pytest.raises(ValueError, match="obs_format='dict'"):
        TeamVecEnv(lambda: teamgym.make("Exploration-v0", obs_format="dict"), n_envs=1, batched=True)
    assert TeamVecEnv(lambda: teamgym.make("Exploration-v0"), n_envs=1).batched


def test_wrapped_envs_are_stepped_one_by_one():
    """A wrapper (here the one that labels expert actions) must see every step: no batch behind its back."""
    from baselines.rl.imitation import ExpertActions

    venv = TeamVecEnv(lambda: ExpertActions(teamgym.make("Navigation-v0", n_robots=2), "goto"), n_envs=2)
    assert not venv.batched
    venv.seed(0)
    venv.reset()
    venv.step_async(np.zeros((venv.num_envs, 2), np.float32))
    _, _, _, infos = venv.step_wait()
    assert all("expert_action" in info for info in infos)
    with pytest.raises(ValueError, match="not a bare teamgym env"):
        TeamVecEnv(lambda: ExpertActions(teamgym.make("Navigation-v0", n_robots=2), "goto"), n_envs=1, batched=True)


def test_ppo_learns_the_same_from_both_paths():
    import torch
    from stable_baselines3 import PPO

    make = lambda: teamgym.make("Navigation-v0", n_robots=2, normalize_actions=True, max_cycles=40)  # noqa: E731
    weights = []
    for batched in (True, False):
        venv = TeamVecEnv(make, n_envs=2, batched=batched)
        model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, n_epochs=2, seed=3, device="cpu", verbose=0)
        model.learn(256)
        weights.append(torch.cat([p.detach().flatten() for p in model.policy.parameters()]))
    assert torch.equal(weights[0], weights[1])
