"""Learned messages: motion ⊕ message actions flattened for PPO/MaskablePPO, sent through the env's channel."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from gymnasium import spaces

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import teamgym  # noqa: E402
from baselines.evaluate import main as evaluate_main  # noqa: E402
from baselines.rl.message_actions import FlatMessageActions, MessageCodec, MessageSettings  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

#: (env id, config): a learned message with continuous and with discrete motion, protocol messages with both.
CASES = [
    ("Navigation-v0", {"comm_dim": 3}),
    ("Navigation-v0", {"comm_dim": 3, "action_type": "heading"}),
    ("Rendezvous-v0", {"protocol_messages": True, "message_len": 8}),
    ("Rendezvous-v0", {"protocol_messages": True, "message_len": 12, "action_type": "velocity"}),
]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def codec_of(env_id: str, config: dict, settings: MessageSettings | None = None) -> tuple[MessageCodec, object]:
    env = teamgym.make(env_id, **config)
    return MessageCodec(env.action_space(env.possible_agents[0]), settings), env


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_flatten_unflatten_round_trip(env_id, config):
    codec, env = codec_of(env_id, config)
    dict_space = env.action_space(env.possible_agents[0])
    assert not isinstance(codec.space, spaces.Dict)
    codec.space.seed(0)
    for _ in range(50):
        flat = codec.space.sample()
        action = codec.decode(flat)
        assert dict_space.contains(action), action
        again = codec.encode(action)
        if isinstance(codec.space, spaces.MultiDiscrete):
            assert np.array_equal(again, flat)  # discrete: exact
        elif not codec.protocol:
            assert np.allclose(again, flat, atol=1e-6)  # a learned Box message keeps its value
        decoded = codec.decode(again)
        assert decoded[codec.motion_key] == pytest.approx(action[codec.motion_key])
        assert np.array_equal(decoded["message"], action["message"])  # decode(encode(a)) == a on the grid


def test_discrete_motion_keeps_the_masks_and_message_values_are_all_admissible():
    codec, env = codec_of("Rendezvous-v0", {"protocol_messages": True, "message_len": 8})
    wrapped = FlatMessageActions(env)
    wrapped.reset(seed=2)
    motion_masks = env.action_masks()
    for agent, mask in wrapped.action_masks().items():
        assert len(mask) == int(np.sum(codec.space.nvec))
        assert np.array_equal(mask[: len(motion_masks[agent])], motion_masks[agent])
        assert mask[len(motion_masks[agent]) :].all()


def test_settings_and_spaces():
    codec, _ = codec_of("Navigation-v0", {"comm_dim": 2, "action_type": "heading"}, MessageSettings(levels=3))
    assert list(codec.space.nvec) == [5, 3, 3]
    assert np.allclose(codec.decode([0, 0, 2])["message"], [-1.0, 1.0])
    codec, _ = codec_of("Rendezvous-v0", {"protocol_messages": True, "message_len": 8}, MessageSettings(tokens=4, vocab=10))
    assert list(codec.space.nvec) == [5, 10, 10, 10, 10]
    assert list(codec.decode([4, 4, 2, 6, 0])["message"]) == [3, 1, 5, -1, -1, -1, -1, -1]
    with pytest.raises(ValueError, match="more than the env's message length"):
        codec_of("Rendezvous-v0", {"protocol_messages": True, "message_len": 8}, MessageSettings(tokens=9))
    with pytest.raises(ValueError, match="apply to protocol messages"):
        codec_of("Navigation-v0", {"comm_dim": 2}, MessageSettings(tokens=4))
    with pytest.raises(ValueError, match="levels must be an integer >= 2"):
        MessageSettings(levels=1).check()


def test_a_learned_message_goes_through_the_channel_with_its_range():
    def inbox_after_one_step(**channel):
        env = FlatMessageActions(teamgym.make("Navigation-v0", comm_dim=2, obs_format="dict", **channel))
        env.reset(seed=0)
        message = np.array([0.5, -0.25])
        zero = np.zeros(2, dtype=np.float32)
        observations, *_ = env.step({a: env.codec.encode({"motion": zero, "message": message}) for a in env.agents})
        return observations["robot_1"]

    heard = inbox_after_one_step()
    assert heard["inbox_mask"].all() and np.allclose(heard["inbox"], [[0.5, -0.25]] * 2)
    out_of_range = inbox_after_one_step(comm_range=1e-3)
    assert not out_of_range["inbox_mask"].any()  # the channel's range applies to the learned messages
    late = inbox_after_one_step(comm_latency=2)
    assert not late["inbox_mask"].any()  # and its latency


def test_a_protocol_record_written_by_the_learner_is_transmitted_and_charged():
    env = FlatMessageActions(teamgym.make("Rendezvous-v0", protocol_messages=True, message_len=8, obs_format="dict"))
    env.reset(seed=0)
    record = {"move": 4, "message": np.array([3, 1, 5, -1, -1, -1, -1, -1])}  # PRESENT place 5, then padding
    silent = {"move": 4, "message": -np.ones(8)}
    observations, _, _, _, infos = env.step({"robot_0": env.codec.encode(record), "robot_1": env.codec.encode(silent)})
    assert list(observations["robot_1"]["messages"][0][:3]) == [3, 1, 5] and observations["robot_1"]["message_mask"][0]
    assert infos["robot_0"]["bytes_sent"] == 12 and infos["robot_1"]["bytes_sent"] == 0  # 4 bytes a value


def train_and_evaluate(tmp_path, name: str, args: list[str]) -> tuple[dict, dict, dict]:
    out = tmp_path / f"{name}.zip"
    small = ["--n-envs", "2", "--hp", "n_steps=32", "--hp", "batch_size=32", "--verbose", "0"]
    evaluation = ["--eval-every", "1000", "--eval-episodes", "3", "--eval-seed", "900"]
    assert train_main([*args, *small, *evaluation, "--timesteps", "128", "--out", str(out)]) == 0
    with open(tmp_path / f"{name}_eval.csv") as handle:
        last = list(csv.DictReader(handle))[-1]
    where = tmp_path / f"ev_{name}"
    assert evaluate_main(["--policy", f"sb3:{out}", "--episodes", "3", "--seed", "900", "--out", str(where), "--quiet"]) == 0
    return json.loads(out.with_suffix(".json").read_text()), last, json.loads((where / "summary.json").read_text())


def test_comm_dim_trains_and_evaluates_to_the_same_numbers(tmp_path):
    sidecar, last, summary = train_and_evaluate(
        tmp_path, "comm", ["--env", "Navigation-v0", "--max-cycles", "25", "--set", "comm_dim=4", "--set", "action_type=heading"]
    )
    assert sidecar["message_actions"] == {"kind": "learned", "motion_key": "motion", "levels": 5, "tokens": None, "vocab": None}
    assert summary["mean_return"] == pytest.approx(float(last["mean_return"]), abs=1e-9)
    assert summary["mean_episode_length"] == pytest.approx(float(last["mean_episode_length"]))
    assert summary["mean_bytes_sent"] > 0  # the trained policy's messages went through the channel


def test_protocol_messages_train_with_maskable_ppo_and_evaluate_to_the_same_numbers(tmp_path):
    args = ["--env", "Rendezvous-v0", "--algo", "maskable-ppo", "--set", "protocol_messages=True", "--set", "message_len=8"]
    sidecar, last, summary = train_and_evaluate(tmp_path, "rdv", [*args, "--max-cycles", "400", "--message-tokens", "6"])
    assert sidecar["message_actions"]["kind"] == "protocol" and sidecar["message_actions"]["tokens"] == 6
    assert summary["mean_return"] == pytest.approx(float(last["mean_return"]), abs=1e-9)
    assert summary["mean_episode_length"] == pytest.approx(float(last["mean_episode_length"]))


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--set", "comm_dim=4", "--algo", "dqn"], "dqn needs Discrete actions"),
        (["--message-levels", "3"], "flatten a motion ⊕ message action"),
        (["--set", "comm_dim=4", "--message-tokens", "3"], "apply to protocol messages"),
    ],
)
def test_bad_message_settings_are_one_line_errors(args, needle, tmp_path, capsys):
    assert train_main(["--env", "Navigation-v0", *args, "--timesteps", "64", "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert needle in err, err


def test_a_message_model_on_an_env_without_messages_is_refused(tmp_path):
    out = tmp_path / "c.zip"
    assert train_main(["--env", "Navigation-v0", "--max-cycles", "20", "--set", "comm_dim=2", "--n-envs", "1",
                       "--hp", "n_steps=32", "--hp", "batch_size=32", "--timesteps", "32", "--verbose", "0",
                       "--out", str(out)]) == 0  # fmt: skip
    with pytest.raises(ValueError, match="motion ⊕ message actions"):
        SB3Policy.load(out, teamgym.make("Navigation-v0"))


def test_maskable_ppo_with_messages_never_picks_a_masked_motion(tmp_path, monkeypatch):
    from baselines.rl.train import train
    from teamgym.envs.exploration import Exploration

    counts = {"actions": 0, "masked": 0}
    step = Exploration.step

    def checking_step(self, actions):
        masks = self.action_masks()
        for agent, action in actions.items():
            counts["actions"] += 1
            counts["masked"] += int(not masks[agent][int(action["motion"])])
        return step(self, actions)

    monkeypatch.setattr(Exploration, "step", checking_step)
    config = {"action_type": "operator", "n_robots": 2, "max_cycles": 60, "comm_dim": 2}
    hp = {"n_steps": 32, "batch_size": 32, "n_epochs": 1}
    out = train("Exploration-v0", "maskable_ppo", 128, out=tmp_path / "m.zip", config=config, n_envs=1, hyperparameters=hp)
    assert counts["actions"] >= 128 and counts["masked"] == 0
    env = teamgym.make("Exploration-v0", **config)
    policy = SB3Policy.load(out, env, deterministic=False)
    from baselines.episode import run_episode

    before = counts["actions"]
    run_episode(env, policy, seed=3)
    assert counts["actions"] > before and counts["masked"] == 0  # evaluation keeps the masks too
