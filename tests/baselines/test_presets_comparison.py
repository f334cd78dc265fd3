"""The critic/memory comparison presets (issue 27): three methods per task that differ in the method only."""

from __future__ import annotations

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

from baselines.rl.presets import load_preset  # noqa: E402
from baselines.rl.train import _plan, build_parser  # noqa: E402

#: task -> (plain, central critic, recurrent) preset names.
COMPARISONS = {
    "navigation": ("navigation-scratch-ppo", "navigation-scratch-central-ppo", "navigation-scratch-recurrent-ppo"),
    "boxpushing-s3": (
        "boxpushing-s3-scratch-ppo",
        "boxpushing-s3-scratch-central-ppo",
        "boxpushing-s3-scratch-recurrent-ppo",
    ),
}

#: The command lines the measured runs were made with (before the presets existed), per preset.
_NAV = [
    "--env", "Navigation-v0", "--set", "local_features=True", "--set", "collision_penalty=5.0", "--n-envs", "8",
    "--timesteps", "153600", "--hp", "n_steps=128", "--hp", "batch_size=768", "--hp", "n_epochs=10",
    "--hp", "learning_rate=1e-4",
]  # fmt: skip
_BOX = [
    "--env", "BoxPushing-v0", "--set", "situation=S3", "--set", "action_type=primitives", "--set", "max_cycles=2000",
    "--n-envs", "8", "--timesteps", "98304", "--hp", "n_steps=256", "--hp", "batch_size=2048", "--hp", "n_epochs=5",
    "--hp", "gamma=0.995", "--hp", "gae_lambda=0.95", "--hp", "learning_rate=3e-4", "--hp", "clip_range=0.2",
    "--hp", "ent_coef=0.01",
]  # fmt: skip
_MLP = ["--hp", "policy_kwargs={'net_arch':[128,128]}"]
_LSTM = ["--algo", "recurrent_ppo", "--hp", "policy_kwargs={'net_arch':[128,128],'lstm_hidden_size':64}"]
MEASURED_COMMANDS = {
    "navigation-scratch-ppo": [*_NAV, *_MLP, "--critic", "local"],
    "navigation-scratch-central-ppo": [*_NAV, *_MLP, "--critic", "central"],
    "navigation-scratch-recurrent-ppo": [*_NAV, *_LSTM],
    "boxpushing-s3-scratch-ppo": [*_BOX, *_MLP, "--critic", "local"],
    "boxpushing-s3-scratch-central-ppo": [*_BOX, *_MLP, "--critic", "central"],
    "boxpushing-s3-scratch-recurrent-ppo": [*_BOX, *_LSTM],
}


def plan(*args: str) -> dict:
    return _plan(build_parser().parse_args([*args, "--seeds", "0,1,2", "--out", "runs/cmp"]))[0]


def _without_method(preset_name: str) -> dict:
    """What a preset trains with, minus the method (algo, critic, the LSTM's size)."""
    preset = load_preset(preset_name)
    policy_kwargs = {k: v for k, v in preset.hyperparameters["policy_kwargs"].items() if k != "lstm_hidden_size"}
    return {
        "env": preset.env,
        "config": preset.config,
        "n_envs": preset.n_envs,
        "timesteps": preset.timesteps,
        "hyperparameters": {**preset.hyperparameters, "policy_kwargs": policy_kwargs},
        "bc": preset.bc,
        "init": preset.init,
        "eval": preset.eval,
    }


@pytest.mark.parametrize("task", sorted(COMPARISONS))
def test_the_three_methods_share_everything_but_the_method(task):
    plain, central, recurrent = COMPARISONS[task]
    assert _without_method(plain) == _without_method(central) == _without_method(recurrent)
    assert plan("--preset", plain)["critic"] == "local" and plan("--preset", plain)["algo"] == "ppo"
    assert plan("--preset", central)["critic"] == "central" and plan("--preset", central)["algo"] == "ppo"
    rec = plan("--preset", recurrent)
    assert rec["algo"] == "recurrent_ppo" and rec.get("critic", "local") == "local"
    assert rec["hyperparameters"]["policy_kwargs"]["lstm_hidden_size"] == 64
    assert "bc_expert" not in rec and "init" not in rec  # from scratch: nothing RecurrentPPO would refuse


@pytest.mark.parametrize("name", sorted(MEASURED_COMMANDS))
def test_each_preset_is_the_command_its_runs_were_measured_with(name):
    from_preset = plan("--preset", name)
    assert from_preset.pop("preset") == name
    assert from_preset == plan(*MEASURED_COMMANDS[name])


def test_recurrent_with_a_central_critic_is_refused_in_one_line(capsys):
    from baselines.rl.train import main

    code = main(["--preset", "navigation-scratch-recurrent-ppo", "--critic", "central", "--out", "unused.zip"])
    assert code == 2
    err = capsys.readouterr().err
    assert "--critic central" in err and "recurrent_ppo" in err and len(err.strip().splitlines()) == 1
