"""Behaviour cloning and DAgger into sb3-contrib's ``MaskablePPO`` (``--algo maskable_ppo --bc-expert ...``).

Foraging-v0's ``goto_cell`` actions are masked, so its clones of ``dmaps`` are MaskablePPO
models; small settings throughout (a few hundred transitions, tens of control steps).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

import teamgym  # noqa: E402
from baselines.rl.imitation import behaviour_clone, collect_expert_data, collect_learner_data  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

#: A field 5 cm wider than the default: its last column of cells lies partly outside and is masked.
MASKED_FIELD = {"field_size": (3.05, 2.4), "max_cycles": 40}


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def maskable_model(make):
    from sb3_contrib import MaskablePPO

    venv = TeamVecEnv(make, n_envs=1)
    return MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu"), venv


def test_maskable_policy_is_cloned_from_expert_labels():
    make = lambda: teamgym.make("Navigation-v0", n_robots=2, action_type="heading")  # noqa: E731
    data = collect_expert_data(make(), "goto", 2000, seed=0, noise=0.3)
    order = np.random.default_rng(0).permutation(len(data))
    held, fit = order[:400], order[400:]
    model, venv = maskable_model(make)
    train = dataclasses.replace(data, observations=data.observations[fit], actions=data.actions[fit], returns=data.returns[fit])

    def accuracy() -> float:
        actions, _ = model.predict(data.observations[held], deterministic=True)
        return float(np.mean(actions == data.actions[held]))

    majority = np.bincount(data.actions[held]).max() / len(held)
    before = accuracy()
    stats = behaviour_clone(model, train, epochs=20, learning_rate=3e-3, seed=0)
    assert np.isfinite(stats["action_loss"]) and accuracy() > max(majority, before), (majority, before, accuracy())
    venv.close()


def test_dagger_rollouts_of_a_maskable_clone_keep_to_the_masks():
    make = lambda: teamgym.make("Foraging-v0", **MASKED_FIELD)  # noqa: E731
    env = make()
    env.reset(seed=0)
    mask = env.action_masks()["robot_0"]
    assert 0 < mask.sum() < mask.size  # the field has masked cells; the env refuses them (a ValueError)
    model, venv = maskable_model(make)
    data = collect_learner_data(make(), model, "dmaps", 120, seed=3)  # an untrained clone driving: masks applied
    assert len(data) == 120 and all(mask[int(a)] for a in data.actions)  # dmaps' labels are admissible cells
    venv.close()


def test_command_line_clones_dmaps_into_maskable_ppo_with_dagger(tmp_path):
    out = tmp_path / "m.zip"
    args = ["--env", "Foraging-v0", "--algo", "maskable_ppo", "--max-cycles", "30", "--n-envs", "1"]
    args += ["--set", "observe_world_model=True", "--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=1"]
    args += ["--bc-expert", "dmaps", "--bc-noise", "0", "--bc-steps", "80", "--bc-epochs", "2", "--bc-dagger", "1"]
    args += ["--bc-dagger-steps", "60", "--timesteps", "64", "--verbose", "0", "--out", str(out)]
    assert train_main(args) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    bc = sidecar["bc"]
    assert sidecar["algo"] == "maskable_ppo" and (bc["expert"], bc["noise"], bc["dagger_rounds"]) == ("dmaps", 0.0, 1)
    assert bc["dagger_transitions"] == 140 and len(bc["dagger_learner_success"]) == 1 and np.isfinite(bc["action_loss"])
