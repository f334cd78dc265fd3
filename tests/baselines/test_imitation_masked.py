"""Behaviour cloning and DAgger for MaskablePPO on masked Discrete actions (Exploration-v0 operators)."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import torch  # noqa: E402

import teamgym  # noqa: E402
from baselines.rl.imitation import (  # noqa: E402
    _masked_cross_entropy,
    behaviour_clone,
    collect_expert_data,
    collect_learner_data,
)
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

CONFIG = {"action_type": "operator", "n_robots": 2}


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def make_env(**extra):
    return teamgym.make("Exploration-v0", **CONFIG, **extra)


def make_model():
    from sb3_contrib import MaskablePPO

    venv = TeamVecEnv(make_env, n_envs=1)
    model = MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu", policy_kwargs={"net_arch": [64]})
    return model, venv


def test_masked_cross_entropy_is_torchs_label_smoothing_when_every_action_is_admissible():
    generator = torch.Generator().manual_seed(0)
    logits = torch.randn(5, 7, generator=generator)
    target = torch.tensor([0, 3, 6, 2, 2])
    allowed = torch.ones(5, 7, dtype=torch.bool)
    log_p = torch.log_softmax(logits, dim=1)
    expected = torch.nn.functional.cross_entropy(logits, target, label_smoothing=0.1)
    assert torch.allclose(_masked_cross_entropy(log_p, target, allowed, 0.1), expected, atol=1e-6)


def test_masked_cross_entropy_smooths_over_the_admissible_actions_only():
    logits = torch.tensor([[0.5, 2.0, -1.0, 0.0]])
    allowed = torch.tensor([[True, True, False, False]])
    log_p = torch.log_softmax(torch.where(allowed, logits, torch.tensor(-1e8)), dim=1)  # as MaskableCategorical
    loss = _masked_cross_entropy(log_p, torch.tensor([1]), allowed, 0.2)
    p = torch.softmax(logits[0, :2], dim=0)
    by_hand = -(0.9 * torch.log(p[1]) + 0.1 * torch.log(p[0]))  # 1 − ε + ε/2 on the label, ε/2 on the other one
    assert torch.isfinite(loss) and torch.allclose(loss, by_hand, atol=1e-6)


def test_expert_data_keep_the_masks_and_perturbations_stay_admissible():
    data = collect_expert_data(make_env(), "nash-explore", 150, seed=3, noise=0.5)
    assert data.masks is not None and data.masks.shape == (150, data.masks.shape[1]) and data.masks.dtype == bool
    assert data.masks[np.arange(150), data.actions].all()  # every label is admissible where it was given
    assert (data.masks.sum(axis=1) < data.masks.shape[1]).all()  # operators are masked: the masks carry information
    merged = data.merged(data)
    assert merged.masks.shape == (300, data.masks.shape[1])
    # noise 0.5 executed random admissible operators; a masked one would have raised in the env's step


def test_maskable_clone_learns_the_expert_and_dagger_gets_masks():
    train = collect_expert_data(make_env(), "nash-explore", 1500, seed=0, noise=0.0)
    held_out = collect_expert_data(make_env(), "nash-explore", 300, seed=900, noise=0.0)
    model, venv = make_model()

    def agreement() -> float:
        actions, _ = model.predict(held_out.observations, deterministic=True, action_masks=held_out.masks)
        assert held_out.masks[np.arange(len(held_out)), actions].all()
        return float(np.mean(actions == held_out.actions))

    before = agreement()
    stats = behaviour_clone(model, train, epochs=15, seed=0)
    after = agreement()
    assert np.isfinite(stats["action_loss"]) and stats["action_loss"] < 5
    assert after > before + 0.2 and after > 0.6, (before, after)
    # the clone drives (with the env's masks, or the env would refuse its operators); nash-explore labels
    fresh = collect_learner_data(make_env(max_cycles=400), model, "nash-explore", 100, seed=5)
    assert len(fresh) == 100 and fresh.masks is not None and fresh.masks[np.arange(100), fresh.actions].all()
    venv.close()


def test_a_label_its_mask_forbids_is_refused():
    data = collect_expert_data(make_env(), "nash-explore", 20, seed=1, noise=0.0)
    data.masks[0, data.actions[0]] = False
    model, venv = make_model()
    with pytest.raises(ValueError, match="action mask forbids"):
        behaviour_clone(model, data, epochs=1)
    venv.close()


def test_command_line_clones_into_maskable_ppo(tmp_path):
    out = tmp_path / "m.zip"
    args = ["--env", "Exploration-v0", "--algo", "maskable_ppo", "--n-envs", "1", "--timesteps", "32", "--verbose", "0"]
    args += ["--set", "action_type=operator", "--set", "n_robots=2", "--set", "max_cycles=300"]
    args += ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=1"]
    bc = ["--bc-expert", "nash-explore", "--bc-noise", "0", "--bc-steps", "60", "--bc-epochs", "2", "--bc-dagger", "1"]
    assert train_main([*args, *bc, "--bc-dagger-steps", "30", "--out", str(out)]) == 0
    record = json.loads(out.with_suffix(".json").read_text())["bc"]
    assert (record["expert"], record["noise"], record["dagger_rounds"], record["dagger_transitions"]) == (
        "nash-explore",
        0.0,
        1,
        90,
    )
    assert record["expert_success_rate"] > 0 and np.isfinite(record["action_loss"])
