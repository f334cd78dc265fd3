"""The S3 BoxPushing preset ``boxpushing-s3-ppo`` and ``--init`` (a new run from saved weights); short runs only."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.rl.presets import load_preset, presets  # noqa: E402
from baselines.rl.train import _plan, build_parser  # noqa: E402
from baselines.rl.train import main as train_main  # noqa: E402

NAME = "boxpushing-s3-ppo"


def plan(*args: str) -> dict:
    return _plan(build_parser().parse_args(list(args)))[0]


def test_s3_preset_loads_builds_the_s3_env_and_plans_its_init():
    assert NAME in presets()
    preset = load_preset(NAME)
    assert preset.env == "BoxPushing-v0" and preset.algo == "ppo" and preset.init == "boxpushing-s1-ppo"
    env = teamgym.make(preset.env, **preset.config)
    try:
        env.reset(seed=0)
        assert len(env.possible_agents) == 4  # S3: four robots, one heavy box
        assert env.config.n_heavy_boxes == 1 and env.config.n_light_boxes == 0
        assert env.action_space("robot_0").n == 13
    finally:
        env.close()
    for key in (*preset.config, "init"):
        assert any(key in documented for documented in preset.changes), f"{key} is not explained"
    kwargs = plan("--preset", NAME, "--out", "m.zip")
    assert kwargs["init"] == "boxpushing-s1-ppo" and kwargs["timesteps"] == preset.timesteps
    assert kwargs["hyperparameters"] == preset.hyperparameters and "bc_expert" not in kwargs
    assert kwargs["critic"] == preset.critic == "central"
    assert plan("--preset", NAME, "--critic", "local", "--out", "m.zip")["critic"] == "local"
    assert plan("--preset", NAME, "--init", "other.zip", "--out", "m.zip")["init"] == "other.zip"
    assert not {"init", "critic"} & set(plan("--preset", "boxpushing-s1-ppo", "--out", "m.zip"))


def test_init_copies_the_weights_and_is_recorded(tmp_path):
    import torch
    from stable_baselines3 import PPO

    from baselines.rl.train import Training

    config = {"situation": "S3", "max_cycles": 20}
    hp = {"n_steps": 32, "batch_size": 64, "policy_kwargs": {"net_arch": [128, 128]}}
    run = Training("BoxPushing-v0", "ppo", 64, 0, tmp_path / "a.zip", config, 1, hp, init="boxpushing-s1-ppo")
    try:
        source = PPO.load("baselines/rl/agents/boxpushing-s1-ppo.zip", device="cpu").policy.state_dict()
        mine = run.model.policy.state_dict()
        assert source.keys() == mine.keys() and all(torch.equal(source[k], mine[k]) for k in source)
    finally:
        run.close()
    out = tmp_path / "s3.zip"
    args = ["--env", "BoxPushing-v0", "--set", "situation=S3", "--set", "max_cycles=20", "--n-envs", "1", "--verbose", "0"]
    args += ["--hp", "n_steps=32", "--hp", "batch_size=64", "--hp", "policy_kwargs={'net_arch': [128, 128]}"]
    assert train_main([*args, "--timesteps", "64", "--init", "boxpushing-s1-ppo", "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["init"]["model"].endswith("boxpushing-s1-ppo.zip") and sidecar["init"]["copied"] == "all"
    assert sidecar["resumed_from"] is None
    assert sidecar["trained_timesteps"] >= 64  # a new run: its own counter from 0


def test_init_into_a_central_critic_copies_the_actor_only(tmp_path):
    import torch
    from stable_baselines3 import PPO

    from baselines.rl.train import ACTOR_KEYS, Training

    config = {"situation": "S3", "max_cycles": 20}
    hp = {"n_steps": 32, "batch_size": 64, "policy_kwargs": {"net_arch": [128, 128]}}
    run = Training("BoxPushing-v0", "ppo", 64, 0, tmp_path / "a.zip", config, 1, hp, init="boxpushing-s1-ppo", critic="central")
    try:
        assert run.init_copied == "actor" and run.model.policy.actor_dim == 21
        source = PPO.load("baselines/rl/agents/boxpushing-s1-ppo.zip", device="cpu").policy.state_dict()
        mine = run.model.policy.state_dict()
        actor = [k for k in source if k.startswith(ACTOR_KEYS)]
        assert actor and all(torch.equal(source[k], mine[k]) for k in actor)
        critic = "mlp_extractor.value_net.0.weight"
        assert source[critic].shape != mine[critic].shape  # the critic reads the team state too: fresh
    finally:
        run.close()


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--init", "boxpushing-s1-ppo", "--resume", "boxpushing-s1-ppo"], "cannot be combined with --resume"),
        (["--env", "BoxPushing-v0", "--set", "situation=S3", "--init", "boxpushing-s1-ppo"], "its network does not fit"),
        (["--env", "BoxPushing-v0", "--set", "observe_stall=True", "--init", "boxpushing-s1-ppo"], "observation_space"),
        (["--init", "no-such-model"], "no saved SB3 model at 'no-such-model'"),
    ],
)
def test_init_errors_are_one_line(args, needle, tmp_path, capsys):
    assert train_main([*args, "--timesteps", "64", "--n-envs", "1", "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1


def test_shipped_s3_agent_plays_s3_from_its_sidecar():
    from baselines.episode import run_episode
    from baselines.registry import make_policy
    from baselines.rl.sb3_policy import read_sidecar, resolve_model, shipped_agents

    assert NAME in shipped_agents()
    sidecar = read_sidecar(resolve_model(NAME))
    assert sidecar["preset"] == NAME and sidecar["critic"] == "central" and sidecar["init"]["copied"] == "actor"
    env = teamgym.make("BoxPushing-v0", **{**sidecar["config"], "max_cycles": 15})
    assert env.config.situation == "S3" and len(env.possible_agents) == 4
    result = run_episode(env, make_policy(f"sb3:{NAME}", env), 31000, record_trajectories=False)
    assert set(result.returns) == set(env.possible_agents) and result.length == 15
