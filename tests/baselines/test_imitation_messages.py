"""Behaviour cloning of motion ⊕ message actions (``comm_dim``): a scripted sender teaches what to send and how to read it.

``place-beacon`` (Rendezvous-v0, ``comm_dim=3``) is the teacher; the learner's action is the flat
``MultiDiscrete`` of :class:`~baselines.rl.message_actions.FlatMessageActions` (motion ⊕ 3 message
values of 9 levels). Small settings throughout.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

import teamgym  # noqa: E402
from baselines.rl.imitation import ExpertActions, behaviour_clone, collect_expert_data, collect_learner_data  # noqa: E402
from baselines.rl.message_actions import FlatMessageActions, MessageSettings  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

TASK = {"comm_dim": 3, "comm_throughput": 0.5, "block_rate": 0.096, "max_cycles": 400}
LEVELS = MessageSettings(levels=9)


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def make_flat() -> FlatMessageActions:
    return FlatMessageActions(teamgym.make("Rendezvous-v0", **TASK), LEVELS)


def test_expert_labels_are_the_flat_actions_of_the_teachers_dict_actions():
    env = make_flat()
    wrapped = ExpertActions(env, "place-beacon")
    observations, infos = wrapped.reset(seed=3)
    for _ in range(6):
        for agent, info in infos.items():
            label = info["expert_action"]
            assert label.shape == (4,) and env.action_space(agent).contains(label)
            assert info["action_mask"].shape == (int(np.sum(env.action_space(agent).nvec)),)  # the flat action's mask
            assert info["action_mask"][int(label[0])]  # the motion is admissible
            message = env.codec.decode(label)["message"]  # back to the teacher's values: a place and a flag
            assert message[2] in (-1.0, 1.0)
            np.testing.assert_allclose(wrapped.policy.message(wrapped.policy.place_of(message), message[2] > 0), message)
        if not wrapped.agents:
            break
        observations, _, _, _, infos = wrapped.step({a: infos[a]["expert_action"] for a in wrapped.agents})


def test_maskable_clone_learns_the_motion_and_the_message():
    from sb3_contrib import MaskablePPO

    data = collect_expert_data(make_flat(), "place-beacon", 1500, seed=0, noise=0.0)
    assert data.actions.shape == (1500, 4) and data.masks.shape == (1500, 5 + 3 * 9)
    order = np.random.default_rng(0).permutation(len(data))
    held, fit = order[:300], order[300:]
    train = dataclasses.replace(
        data, observations=data.observations[fit], actions=data.actions[fit], returns=data.returns[fit], masks=data.masks[fit]
    )
    venv = TeamVecEnv(make_flat, n_envs=1)
    model = MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu")

    def accuracy() -> np.ndarray:
        actions, _ = model.predict(data.observations[held], deterministic=True, action_masks=data.masks[held])
        return np.mean(actions == data.actions[held], axis=0)

    majority = np.array([np.bincount(data.actions[held, j]).max() / len(held) for j in range(4)])
    stats = behaviour_clone(model, train, epochs=30, learning_rate=3e-3, seed=0)
    after = accuracy()
    assert np.isfinite(stats["action_loss"])
    assert after[0] > majority[0] and after[1:3].mean() > majority[1:3].mean(), (majority, after)  # motion and place
    venv.close()


def test_recurrent_clone_of_message_actions_fits_and_dagger_keeps_to_the_masks():
    from sb3_contrib import RecurrentPPO

    from baselines.rl.masked_recurrent import MaskedLstmPolicy, MasksInObservation

    data = collect_expert_data(make_flat(), "place-beacon", 400, seed=1, noise=0.0)
    venv = MasksInObservation(TeamVecEnv(make_flat, n_envs=1))
    model = RecurrentPPO(
        MaskedLstmPolicy,
        venv,
        n_steps=32,
        batch_size=32,
        seed=0,
        device="cpu",
        policy_kwargs={"mask_width": venv.width, "lstm_hidden_size": 32},
    )
    first = behaviour_clone(model, data, epochs=1, learning_rate=3e-3, seed=0)
    last = behaviour_clone(model, data, epochs=15, learning_rate=3e-3, seed=0)
    assert last["action_loss"] < first["action_loss"]
    fresh = collect_learner_data(make_flat(), model, "place-beacon", 120, seed=5)  # the clone drives with the masks
    assert fresh.masks is not None and all(fresh.masks[t, int(fresh.actions[t, 0])] for t in range(len(fresh)))
    venv.close()


def test_command_line_clones_place_beacon_into_a_message_policy(tmp_path):
    out = tmp_path / "m.zip"
    args = ["--env", "Rendezvous-v0", "--algo", "maskable_ppo", "--n-envs", "1", "--message-levels", "9"]
    for key, value in TASK.items():
        args += ["--set", f"{key}={value}"]
    args += ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=1", "--bc-expert", "place-beacon"]
    args += ["--bc-noise", "0", "--bc-steps", "200", "--bc-epochs", "2", "--bc-dagger", "1", "--bc-dagger-steps", "60"]
    args += ["--timesteps", "32", "--verbose", "0", "--out", str(out)]
    assert train_main(args) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["bc"]["expert"] == "place-beacon" and sidecar["bc"]["dagger_transitions"] == 260
    assert sidecar["message_actions"]["levels"] == 9 and np.isfinite(sidecar["bc"]["action_loss"])


def test_noise_perturbs_each_part_of_a_message_action_within_its_mask():
    from gymnasium import spaces

    from baselines.rl.imitation import _perturb

    space, rng = spaces.MultiDiscrete([5, 9, 9, 9]), np.random.default_rng(0)
    mask = np.ones(5 + 27, dtype=bool)
    mask[[0, 3]] = False  # motions 0 and 3 masked
    drawn = np.stack([_perturb(space, np.array([1, 4, 4, 4]), 1.0, rng, mask) for _ in range(400)])
    assert set(drawn[:, 0]) == {1, 2, 4} and all(len(set(drawn[:, j])) == 9 for j in (1, 2, 3))
    assert np.array_equal(_perturb(space, np.array([1, 4, 4, 4]), 0.0, rng, mask), [1, 4, 4, 4])
    noisy = collect_expert_data(make_flat(), "place-beacon", 300, seed=2, noise=0.5)  # the env refuses a masked motion
    clean = collect_expert_data(make_flat(), "place-beacon", 300, seed=2, noise=0.0)
    assert not np.array_equal(noisy.observations, clean.observations)  # perturbed actions were executed
