"""Recurrent policies (``--algo recurrent-ppo``): each robot's LSTM state carried through an episode, reset at its start."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

from sb3_contrib import RecurrentPPO  # noqa: E402

import teamgym  # noqa: E402
from baselines.episode import run_episode  # noqa: E402
from baselines.evaluate import main as evaluate_main  # noqa: E402
from baselines.rl.recurrent import AgentMemory  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy, detect_algorithm  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

CONFIG = {"max_cycles": 25}
SMALL = ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "policy_kwargs={'lstm_hidden_size': 16}"]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def untrained(seed: int = 0) -> tuple[RecurrentPPO, TeamVecEnv]:
    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", **CONFIG), n_envs=1)
    model = RecurrentPPO("MlpLstmPolicy", venv, n_steps=16, batch_size=16, seed=seed, device="cpu")
    return model, venv


def test_two_actions_on_the_same_observation_differ_and_reset_restarts_the_memory():
    model, venv = untrained()
    env = teamgym.make("Navigation-v0", **CONFIG)
    policy = SB3Policy(env, model)
    observations, _ = env.reset(seed=3)
    policy.reset(3)
    first = policy.act(observations)
    second = policy.act(observations)  # the same observation, one step of memory later
    assert any(not np.allclose(first[a], second[a]) for a in first)
    policy.reset(4)  # a new episode: every robot starts from a zero state again
    again = policy.act(observations)
    assert all(np.allclose(first[a], again[a]) for a in first)
    venv.close()


def test_each_robot_keeps_its_own_state_when_another_leaves():
    model, venv = untrained()
    env = teamgym.make("Navigation-v0", **CONFIG)
    policy = SB3Policy(env, model)
    observations, _ = env.reset(seed=5)
    policy.reset(5)
    policy.act(observations)
    both = policy.act(observations)
    alone = SB3Policy(env, model)
    alone.reset(5)
    kept = "robot_1"
    alone.act(observations)
    # robot_0 left after the first step: robot_1's second action is the same as with robot_0 present
    only = alone.act({kept: observations[kept]})
    assert np.allclose(both[kept], only[kept])
    venv.close()


def manual_episode(model: RecurrentPPO, env, seed: int) -> tuple[float, int]:
    """One deterministic episode with model.predict and the LSTM state carried by hand (a dict per robot)."""
    observations, _ = env.reset(seed=seed)
    states: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    total, length = 0.0, 0
    while env.agents:
        actions = {}
        for agent in env.agents:
            state = states.get(agent)
            action, state = model.predict(
                observations[agent][None], state=state, episode_start=np.array([agent not in states]), deterministic=True
            )
            states[agent] = state
            actions[agent] = np.clip(action[0], env.action_space(agent).low, env.action_space(agent).high)
        observations, rewards, _, _, _ = env.step(actions)
        total += sum(rewards.values())
        length += 1
    return total / len(env.possible_agents), length


def test_run_episode_equals_a_manual_loop_carrying_the_state():
    model, venv = untrained(seed=1)
    env = teamgym.make("Navigation-v0", **CONFIG)
    policy = SB3Policy(env, model)
    for seed in (11, 12):
        result = run_episode(env, policy, seed)
        mean_return, length = manual_episode(model, teamgym.make("Navigation-v0", **CONFIG), seed)
        assert result.length == length
        assert result.mean_return == pytest.approx(mean_return, abs=1e-5)
    venv.close()


def test_agent_memory_refuses_a_feed_forward_model():
    from stable_baselines3 import PPO

    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", **CONFIG), n_envs=1)
    with pytest.raises(ValueError, match="no recurrent policy"):
        AgentMemory(PPO("MlpPolicy", venv, n_steps=16, batch_size=16, device="cpu"))
    venv.close()


def test_train_save_evaluate_gives_training_evaluation_numbers(tmp_path, capsys):
    out = tmp_path / "rec.zip"
    args = ["--env", "Navigation-v0", "--algo", "recurrent-ppo", "--max-cycles", "25", "--n-envs", "2", *SMALL]
    evaluation = ["--eval-every", "1000", "--eval-episodes", "3", "--eval-seed", "700"]
    assert train_main([*args, *evaluation, "--timesteps", "128", "--verbose", "0", "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["algo"] == "recurrent_ppo"
    with open(tmp_path / "rec_eval.csv") as handle:
        last = list(csv.DictReader(handle))[-1]
    summary_dir = tmp_path / "ev"
    assert (
        evaluate_main(["--policy", f"sb3:{out}", "--episodes", "3", "--seed", "700", "--out", str(summary_dir), "--quiet"]) == 0
    )
    summary = json.loads((summary_dir / "summary.json").read_text())
    assert summary["mean_return"] == pytest.approx(float(last["mean_return"]), abs=1e-9)
    assert summary["mean_episode_length"] == pytest.approx(float(last["mean_episode_length"]))
    # the loader reads it as RecurrentPPO, with or without the sidecar
    env = teamgym.make("Navigation-v0", **CONFIG)
    assert SB3Policy.load(out, env).memory is not None
    out.with_suffix(".json").unlink()
    assert detect_algorithm(out) == "recurrent_ppo"
    policy = SB3Policy.load(out, env)
    assert policy.algo == "recurrent_ppo" and policy.memory is not None


def test_masked_action_types_are_refused_in_one_line(tmp_path, capsys):
    args = ["--env", "Exploration-v0", "--algo", "recurrent-ppo", "--set", "action_type=operator", "--timesteps", "64"]
    assert train_main([*args, "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1, err
    assert "no masked RecurrentPPO" in err and "maskable-ppo" in err
    assert not list(tmp_path.iterdir())


# -- the masked variant (--algo maskable-recurrent-ppo) ------------------------------------------------

EXPLORATION = {"action_type": "operator", "n_robots": 2, "max_cycles": 60}


def count_masked(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Count the operators Exploration is given and those its masks forbid (one by one and as a batch)."""
    from teamgym.envs.batch import TeamBatch
    from teamgym.envs.exploration import Exploration

    counts = {"actions": 0, "masked": 0}
    step, batch_step = Exploration.step, TeamBatch.step

    def checking_step(self, actions):
        masks = self.action_masks()
        for agent, action in actions.items():
            counts["actions"] += 1
            counts["masked"] += int(not masks[agent][int(action)])
        return step(self, actions)

    def checking_batch_step(self, actions):
        masks, active = self.action_masks(), self.active
        for k, i in zip(*np.nonzero(active)):
            counts["actions"] += 1
            counts["masked"] += int(not masks[k, i, int(actions[k, i])])
        return batch_step(self, actions)

    monkeypatch.setattr(Exploration, "step", checking_step)
    monkeypatch.setattr(TeamBatch, "step", checking_batch_step)
    return counts


def test_masked_lstm_policy_samples_and_scores_only_admissible_actions():
    import torch

    from baselines.rl.masked_recurrent import MaskedLstmPolicy, MasksInObservation

    venv = MasksInObservation(TeamVecEnv(lambda: teamgym.make("Exploration-v0", **EXPLORATION), n_envs=1))
    width = venv.width
    model = RecurrentPPO(
        MaskedLstmPolicy, venv, n_steps=16, batch_size=16, device="cpu", seed=0, policy_kwargs={"mask_width": width}
    )
    obs = np.repeat(venv.reset()[:1], 64, axis=0)
    only = 7
    obs[:, -width:] = 0
    obs[:, -width + only] = 1  # one admissible action
    states = np.zeros((1, 64, model.policy.lstm_hidden_state_shape[2]), np.float32)
    actions, _ = model.predict(obs, state=(states, states), episode_start=np.ones(64, bool), deterministic=False)
    assert set(actions.tolist()) == {only}
    free = obs.copy()
    free[:, -width:] = 1
    sampled, _ = model.predict(free, state=(states, states), episode_start=np.ones(64, bool), deterministic=False)
    assert len(set(sampled.tolist())) > 1  # unmasked, the same policy spreads its actions
    tensor = torch.as_tensor(obs)
    lstm = (torch.zeros(1, 64, states.shape[2]), torch.zeros(1, 64, states.shape[2]))
    from sb3_contrib.common.recurrent.type_aliases import RNNStates

    _, log_prob, _ = model.policy.evaluate_actions(
        tensor, torch.full((64,), only), RNNStates(lstm, lstm), torch.ones(64)
    )  # fmt: skip
    assert torch.allclose(log_prob, torch.zeros(64), atol=1e-5)  # the one admissible action has probability 1
    _, masked_log_prob, _ = model.policy.evaluate_actions(tensor, torch.full((64,), 3), RNNStates(lstm, lstm), torch.ones(64))
    assert (masked_log_prob < -1e6).all()
    venv.close()


def test_maskable_recurrent_trains_and_evaluates_without_a_masked_action(tmp_path, monkeypatch):
    counts = count_masked(monkeypatch)
    out = tmp_path / "mr.zip"
    args = ["--env", "Exploration-v0", "--algo", "maskable-recurrent-ppo", "--n-envs", "2", *SMALL]
    args += [f"--set={k}={v}" for k, v in EXPLORATION.items()]
    evaluation = ["--eval-every", "1000", "--eval-episodes", "2", "--eval-seed", "800"]
    assert train_main([*args, *evaluation, "--timesteps", "128", "--verbose", "0", "--out", str(out)]) == 0
    assert counts["actions"] >= 128 and counts["masked"] == 0
    with open(tmp_path / "mr_eval.csv") as handle:
        last = list(csv.DictReader(handle))[-1]
    where = tmp_path / "ev"
    assert evaluate_main(["--policy", f"sb3:{out}", "--episodes", "2", "--seed", "800", "--out", str(where), "--quiet"]) == 0
    summary = json.loads((where / "summary.json").read_text())
    assert summary["mean_return"] == pytest.approx(float(last["mean_return"]), abs=1e-9)
    assert counts["masked"] == 0
    out.with_suffix(".json").unlink()
    assert detect_algorithm(out) == "maskable_recurrent_ppo"
