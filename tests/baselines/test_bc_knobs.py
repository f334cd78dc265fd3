"""The imitation knobs of ``baselines.train``: ``--bc-noise`` and the cloning settings, recorded in the sidecar and applied."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.episode import run_episode  # noqa: E402
from baselines.registry import make_policy  # noqa: E402
from baselines.rl import imitation  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

CONFIG = {"n_robots": 2, "max_cycles": 40}
ENV_ARGS = ["--set", "n_robots=2", "--max-cycles", "40", "--n-envs", "1"]
PPO_ARGS = ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=1", "--verbose", "0", "--timesteps", "32"]
#: Fewer transitions than one goto episode of 2 robots: the expert data are exactly the first (seeded) episode.
BC = ["--bc-expert", "goto", "--bc-steps", "20", "--bc-epochs", "1"]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def bc_record(tmp_path, *extra: str, seed: int = 4) -> dict:
    out = tmp_path / "m.zip"
    assert train_main([*ENV_ARGS, *PPO_ARGS, *BC, *extra, "--seed", str(seed), "--out", str(out)]) == 0
    return json.loads(out.with_suffix(".json").read_text())["bc"]


def test_default_noise_is_unchanged_and_every_cloning_setting_is_recorded(tmp_path):
    record = bc_record(tmp_path)
    assert record["noise"] == imitation.DEFAULT_BC_NOISE == 0.5
    assert record["batch_size"] == 64 and record["learning_rate"] == 1e-3 and record["fit_value"] is True
    assert record["std_fraction"] == imitation.DEFAULT_STD_FRACTION and record["label_smoothing"] == 0.1


def test_zero_noise_collects_the_expert_s_own_episode(tmp_path):
    goto = teamgym.make("Navigation-v0", **CONFIG)
    clean = run_episode(goto, make_policy("goto", goto), seed=4)
    record = bc_record(tmp_path, "--bc-noise", "0")
    assert record["noise"] == 0.0 and record["expert_episodes"] == 1
    assert record["expert_mean_return"] == pytest.approx(clean.mean_return, abs=1e-9)  # no perturbation applied
    noisy = bc_record(tmp_path, "--bc-noise", "0.9")
    assert noisy["noise"] == 0.9 and noisy["expert_mean_return"] != pytest.approx(clean.mean_return, abs=1e-6)


def test_cloning_settings_reach_behaviour_clone(tmp_path, monkeypatch):
    seen: dict = {}
    clone = imitation.behaviour_clone

    def spy(model, data, epochs, **options):
        seen.update(options)
        return clone(model, data, epochs, **options)

    monkeypatch.setattr(imitation, "behaviour_clone", spy)
    knobs = ["--bc-batch-size", "16", "--bc-lr", "3e-4", "--bc-std-fraction", "0.3", "--bc-label-smoothing", "0", "--bc-no-value"]
    record = bc_record(tmp_path, *knobs)
    expected = {"batch_size": 16, "learning_rate": 3e-4, "std_fraction": 0.3, "label_smoothing": 0.0, "fit_value": False}
    assert {k: seen[k] for k in expected} == expected
    assert {k: record[k] for k in expected} == expected


def test_dagger_amounts_on_the_command_line(tmp_path):
    record = bc_record(tmp_path, "--bc-dagger", "1", "--bc-dagger-steps", "10", "--bc-dagger-epochs", "1")
    assert record["dagger_rounds"] == 1 and record["dagger_steps"] == 10 and record["dagger_transitions"] == 30


def test_expert_arguments_on_the_command_line(tmp_path):
    """``--bc-expert-kwargs`` builds the expert with them (a slower goto: another expert return), and the sidecar keeps them."""
    default = bc_record(tmp_path, "--bc-noise", "0")
    slow = bc_record(tmp_path, "--bc-noise", "0", "--bc-expert-kwargs", '{"v_cruise": 0.1}')
    assert slow["expert_kwargs"] == {"v_cruise": 0.1} and "expert_kwargs" not in default
    assert slow["expert_mean_return"] != pytest.approx(default["expert_mean_return"], abs=1e-6)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--bc-noise", "0.2"], "--bc-noise need --bc-expert"),
        (["--bc-expert-kwargs", "{}"], "--bc-expert-kwargs need --bc-expert"),
        ([*BC, "--bc-expert-kwargs", "[]"], "--bc-expert-kwargs: expected a JSON object"),
        ([*BC, "--bc-expert-kwargs", '{"speed": 1}'], "unexpected keyword argument 'speed'"),
        ([*BC, "--bc-noise", "1.5"], "--bc-noise: expected a number in [0, 1]"),
        ([*BC, "--bc-lr", "0"], "--bc-lr"),
        ([*BC, "--bc-label-smoothing", "1"], "--bc-label-smoothing"),
        (["--bc-dagger-steps", "5"], "need --bc-expert"),
    ],
)
def test_bad_knobs_are_one_line_errors_before_any_work(args, needle, tmp_path, capsys):
    assert train_main([*ENV_ARGS, *PPO_ARGS, *args, "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert needle in err, err
    assert not list(tmp_path.iterdir())
