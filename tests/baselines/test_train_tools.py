"""Research tooling of ``python -m baselines.train``: TensorBoard, progress bar, checkpoints, resume,
held-out evaluation during training, sidecar-driven ``baselines.evaluate``, multi-seed runs and
learning curves (``baselines.rl.plot_curves``).

Every training here is tiny: PPO with rollouts of 32 steps on one env copy of two robots,
i.e. 64 agent transitions per rollout, for 64 to 256 timesteps.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.evaluate import evaluate  # noqa: E402
from baselines.evaluate import main as evaluate_main  # noqa: E402
from baselines.rl import plot_curves  # noqa: E402
from baselines.rl.callbacks import EvalLog, is_better  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy  # noqa: E402
from baselines.rl.train import Training, continued_path, train  # noqa: E402
from baselines.summary import summarise  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

ENV_ARGS = ["--set", "n_robots=2", "--max-cycles", "10", "--n-envs", "1"]
PPO_ARGS = ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=2", "--verbose", "0"]
EVAL_ARGS = ["--eval-every", "64", "--eval-episodes", "3", "--eval-seed", "500"]
OVERRIDES = {"n_robots": "2", "max_cycles": "10"}
TRAIN_KWARGS = {
    "env_id": "Navigation-v0",
    "config": OVERRIDES,
    "n_envs": 1,
    "hyperparameters": {"n_steps": 32, "batch_size": 32, "n_epochs": 2},
}


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def one_line_error(err: str, needle: str) -> None:
    assert err.startswith("error: "), err
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    assert needle in err, err


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open() as handle:
        return list(csv.DictReader(handle))


def weights(path: Path) -> dict[str, np.ndarray]:
    from stable_baselines3 import PPO

    return {k: v.numpy().copy() for k, v in PPO.load(str(path), device="cpu").policy.state_dict().items()}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One 128-timestep run with TensorBoard, the progress bar, checkpoints and evaluations every 64 timesteps."""
    import stable_baselines3.common.base_class as base_class
    from stable_baselines3.common.callbacks import ProgressBarCallback

    directory = tmp_path_factory.mktemp("train")
    bar_steps = []

    class CountingProgressBar(ProgressBarCallback):
        def _on_step(self) -> bool:
            bar_steps.append(self.num_timesteps)
            return super()._on_step()

    args = ["--timesteps", "128", *ENV_ARGS, *PPO_ARGS, *EVAL_ARGS, "--checkpoint-every", "64"]
    args += ["--tensorboard", str(directory / "tb"), "--progress-bar", "--out", str(directory / "m.zip")]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(base_class, "ProgressBarCallback", CountingProgressBar)
        code = train_main(args)
    return {"code": code, "dir": directory, "out": directory / "m.zip", "bar_steps": bar_steps}


def test_tensorboard_logs_and_progress_bar(run):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    assert run["code"] == 0
    assert run["bar_steps"][-1] == 128 and len(run["bar_steps"]) == 64  # SB3's rich bar saw every step
    (log_dir,) = (run["dir"] / "tb").iterdir()
    assert log_dir.name == "m_1"  # tb_log_name is the model's stem
    events = EventAccumulator(str(log_dir))
    events.Reload()
    tags = events.Tags()["scalars"]
    assert {"eval/success_rate", "eval/mean_return", "eval/mean_distance_to_goal", "time/fps", "train/loss"} <= set(tags)
    rows = read_rows(run["dir"] / "m_eval.csv")
    logged = events.Scalars("eval/mean_return")
    assert [e.step for e in logged] == [int(r["timesteps"]) for r in rows] == [0, 64, 128]
    assert [e.value for e in logged] == pytest.approx([float(r["mean_return"]) for r in rows], rel=1e-6)


def test_checkpoints_every_n_timesteps_with_sidecars(run):
    out = run["out"]
    assert sorted(p.name for p in out.parent.glob("m_*_steps.*")) == [
        "m_128_steps.json",
        "m_128_steps.zip",
        "m_64_steps.json",
        "m_64_steps.zip",
    ]
    for steps in (64, 128):
        meta = json.loads((out.parent / f"m_{steps}_steps.json").read_text())
        assert meta["kind"] == "checkpoint" and meta["trained_timesteps"] == steps
        assert meta["env"] == "Navigation-v0" and meta["overrides"] == OVERRIDES
    final = json.loads(out.with_suffix(".json").read_text())
    assert final["kind"] == "final" and final["trained_timesteps"] == 128 and final["checkpoint_every"] == 64
    assert final["eval"] == {
        "every": 64,
        "episodes": 3,
        "seed": 500,
        "csv": str(out.parent / "m_eval.csv"),
        "best": str(out.parent / "m_best.zip"),
    }
    # the last checkpoint is the final model (both taken after the update that follows the last rollout)
    last, final_weights = weights(out.parent / "m_128_steps.zip"), weights(out)
    assert all(np.array_equal(last[k], final_weights[k]) for k in final_weights)


def test_periodic_evaluation_is_baselines_evaluate_on_held_out_seeds(run):
    out = run["out"]
    rows = read_rows(out.parent / "m_eval.csv")
    with (out.parent / "m_eval.csv").open() as handle:
        header = next(csv.reader(handle))
    assert header[:4] == ["timesteps", "success_rate", "mean_return", "mean_episode_length"]
    assert "mean_distance_to_goal" in header and "mean_success" not in header
    by_step = {int(r["timesteps"]): r for r in rows}
    for steps, model in [(64, out.parent / "m_64_steps.zip"), (128, out)]:
        summary = summarise(evaluate("Navigation-v0", f"sb3:{model}", episodes=3, seed=500, config=OVERRIDES))
        for column in ("success_rate", "mean_return", "mean_episode_length", "mean_distance_to_goal", "mean_path_length"):
            assert float(by_step[steps][column]) == pytest.approx(summary[column], rel=1e-12, abs=1e-15), (steps, column)
    best = json.loads((out.parent / "m_best.json").read_text())
    assert best["kind"] == "best"
    numeric = [{k: float(v) for k, v in r.items()} for r in rows]
    expected = numeric[0]
    for row in numeric[1:]:
        if is_better(row, expected):
            expected = row
    assert best["best_eval"]["timesteps"] == int(expected["timesteps"])
    summary = summarise(evaluate("Navigation-v0", f"sb3:{out.parent / 'm_best.zip'}", episodes=3, seed=500, config=OVERRIDES))
    assert summary["mean_return"] == pytest.approx(expected["mean_return"], rel=1e-12)


def test_evaluation_and_logging_do_not_change_training(run, tmp_path):
    plain = train(timesteps=128, seed=0, out=tmp_path / "plain.zip", **TRAIN_KWARGS)
    a, b = weights(plain), weights(run["out"])
    assert set(a) == set(b) and all(np.array_equal(a[k], b[k]) for k in a)
    assert not any(tmp_path.glob("plain_*"))  # no eval CSV, best model or checkpoints when they are off


def copy_run(run, into: Path, names: list[str]) -> Path:
    into.mkdir()
    for name in names:
        source = run["dir"] / name
        (shutil.copytree if source.is_dir() else shutil.copy)(source, into / name)
    return into


def test_resume_adds_up_timesteps_and_continues_logs(run, tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    d = copy_run(run, tmp_path / "a", ["m.zip", "m.json", "m_eval.csv", "m_best.zip", "m_best.json", "tb"])
    args = ["--resume", str(d / "m.zip"), "--timesteps", "128", "--verbose", "0", "--tensorboard", str(d / "tb")]
    assert train_main(args) == 0  # no --set: env, config, eval and checkpoint settings come from the sidecar
    meta = json.loads((d / "m.json").read_text())
    assert meta["trained_timesteps"] == 256 and meta["resumed_at"] == 128 and meta["timesteps"] == 128
    assert meta["resumed_from"] == str(d / "m.zip") and meta["overrides"] == OVERRIDES
    assert meta["config"]["n_robots"] == 2 and meta["reset_seed"] == 128
    assert meta["hyperparameters"] == json.loads((run["out"].with_suffix(".json")).read_text())["hyperparameters"]
    assert [int(r["timesteps"]) for r in read_rows(d / "m_eval.csv")] == [0, 64, 128, 192, 256]
    assert {p.name for p in d.glob("m_*_steps.zip")} == {"m_192_steps.zip", "m_256_steps.zip"}
    assert [p.name for p in (d / "tb").iterdir()] == ["m_1"]  # the same TensorBoard run continues
    events = EventAccumulator(str(d / "tb" / "m_1"))
    events.Reload()
    assert [e.step for e in events.Scalars("eval/success_rate")] == [0, 64, 128, 192, 256]
    best = json.loads((d / "m_best.json").read_text())["best_eval"]
    assert best["timesteps"] in (0, 64, 128, 192, 256) and best["success_rate"] >= 0.0
    model = SB3Policy.load(d / "m.zip", teamgym.make("Navigation-v0", n_robots=2)).model
    assert model.num_timesteps == 256


def test_resume_from_a_checkpoint_continues_its_run(run, tmp_path):
    d = copy_run(run, tmp_path / "b", ["m_64_steps.zip", "m_64_steps.json", "m_eval.csv"])
    sidecar = json.loads((d / "m_64_steps.json").read_text())
    (d / "m_64_steps.json").write_text(json.dumps({**sidecar, "tensorboard": str(d / "tb2")}))
    assert continued_path(d / "m_64_steps.zip") == d / "m.zip"
    assert continued_path(d / "m_best.zip") == d / "m.zip" and continued_path(d / "other.zip") == d / "other.zip"
    args = ["--resume", str(d / "m_64_steps"), "--timesteps", "64", "--checkpoint-every", "0", "--verbose", "0"]
    assert train_main(args) == 0
    meta = json.loads((d / "m.json").read_text())
    assert meta["trained_timesteps"] == 128 and meta["resumed_at"] == 64 and meta["checkpoint_every"] is None
    assert meta["tensorboard"] == str(d / "tb2")  # kept from the sidecar
    assert [p.name for p in (d / "tb2").iterdir()] == ["m_1"]  # a new TensorBoard folder starts at run 1
    # rows after the checkpoint (from the first run) are replaced by the continued run's
    assert [int(r["timesteps"]) for r in read_rows(d / "m_eval.csv")] == [0, 64, 128]
    assert not list(d.glob("m_128_steps.zip"))


def test_default_command_line_is_unchanged():
    from baselines.rl.train import _plan, build_parser

    kwargs, seeds = _plan(build_parser().parse_args(["--env", "Navigation-v0", "--algo", "ppo", "--timesteps", "200000"]))
    assert seeds is None
    assert kwargs == {
        "env_id": "Navigation-v0",
        "algo": "ppo",
        "timesteps": 200_000,
        "config": {},
        "n_envs": 4,
        "hyperparameters": {},
        "verbose": 1,
        "threads": 1,
        "tensorboard_log": None,
        "progress_bar": False,
        "checkpoint_every": None,
        "eval_every": None,
        "eval_episodes": 10,
        "eval_seed": 10_000,
        "out": Path("results") / "models" / "Navigation-v0_ppo.zip",
        "seed": 0,
    }


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--seed", "1", "--seeds", "0,1"], "not both"),
        (["--jobs", "2"], "--jobs needs --seeds"),
        (["--seeds", "0,0"], "distinct seeds"),
        (["--seeds", "a,b"], "comma-separated"),
        (["--seeds", "0,1", "--jobs", "2", "--progress-bar"], "--progress-bar"),
        (["--eval-episodes", "3"], "need --eval-every"),
        (["--hp", "bogus=1"], "'bogus' is not a hyperparameter of PPO"),
        (["--timesteps", "0"], "--timesteps"),
        (["--checkpoint-every", "-5"], "--checkpoint-every"),
        (["--eval-every", "64", "--eval-seed", "0", *ENV_ARGS], "reset seeds [0]"),
        (["--resume", "/no/such/model.zip"], "no saved SB3 model"),
        (["--algo", "nope"], "--algo"),
        (["--set", "bogus=1"], "bogus"),
    ],
)
def test_usage_errors_are_one_line_and_train_nothing(args, needle, tmp_path, capsys):
    assert train_main([*args, "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not any(tmp_path.iterdir())


def test_seeds_need_an_output_directory(tmp_path, capsys):
    assert train_main(["--seeds", "0,1", "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, "names a directory")


def test_resume_mismatches_are_usage_errors(run, capsys):
    assert train_main(["--resume", str(run["out"]), "--algo", "sac", "--timesteps", "64"]) == 2
    one_line_error(capsys.readouterr().err, "trained with ppo")
    assert train_main(["--resume", str(run["out"]), "--env", "BoxPushing-v0", "--timesteps", "64"]) == 2
    one_line_error(capsys.readouterr().err, "do not match")


def test_missing_packages_are_usage_errors(monkeypatch, tmp_path, capsys):
    import importlib.util

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name in ("rich", "tensorboard") else find_spec(name, *a)
    )
    assert train_main(["--progress-bar", "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, "needs the rich package")
    assert train_main(["--tensorboard", str(tmp_path / "tb"), "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, "needs the tensorboard package")


def test_interrupt_saves_the_model_trained_so_far(tmp_path, monkeypatch, capsys):
    from stable_baselines3.common.callbacks import BaseCallback

    class Interrupt(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps >= 80:
                raise KeyboardInterrupt
            return True

    out = tmp_path / "m.zip"
    with pytest.raises(KeyboardInterrupt):
        train(timesteps=256, seed=0, out=out, callback=Interrupt(), **TRAIN_KWARGS)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["interrupted"] is True and meta["trained_timesteps"] == 80

    def interrupted(self):
        raise KeyboardInterrupt

    monkeypatch.setattr(Training, "learn", interrupted)
    assert train_main([*ENV_ARGS, "--out", str(tmp_path / "n.zip")]) == 130
    one_line_error(capsys.readouterr().err, f"--resume {tmp_path / 'n.zip'}")


# -- baselines.evaluate with a model's sidecar --------------------------------------------


def test_evaluate_takes_env_and_config_from_the_sidecar(run, tmp_path):
    model = f"sb3:{run['out']}"
    assert evaluate_main(["--policy", model, "--episodes", "1", "--out", str(tmp_path / "a"), "--quiet"]) == 0
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["env"] == "Navigation-v0" and summary["config"]["n_robots"] == 2 and summary["config"]["max_cycles"] == 10
    assert summary["sidecar"] == str(run["out"].with_suffix(".json")) and summary["deterministic"] is True
    assert summary["overrides"] == OVERRIDES
    # explicit settings win, key by key
    args = ["--policy", model, "--episodes", "1", "--set", "max_cycles=5", "--out", str(tmp_path / "b"), "--quiet"]
    assert evaluate_main(args) == 0
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["config"]["max_cycles"] == 5 and summary["config"]["n_robots"] == 2
    assert json.loads((tmp_path / "b" / "summary.json").read_text())["mean_episode_length"] <= 5


def test_evaluate_on_another_env(run, tmp_path, monkeypatch, capsys):
    model = f"sb3:{run['out']}"
    args = ["--policy", model, "--episodes", "1", "--quiet"]
    assert evaluate_main([*args, "--env", "BoxPushing-v0", "--out", str(tmp_path / "a")]) == 2
    one_line_error(capsys.readouterr().err, "the model was trained on Navigation-v0")
    assert not (tmp_path / "a").exists()
    # another env id whose spaces fit: accepted with a note, without the sidecar's config
    monkeypatch.setitem(teamgym.registry._REGISTRY, "NavigationCopy-v0", "teamgym.envs.navigation:Navigation")
    assert evaluate_main([*args, "--env", "NavigationCopy-v0", "--out", str(tmp_path / "b")]) == 2  # 3 robots: no fit
    one_line_error(capsys.readouterr().err, "observations of shape")
    assert evaluate_main([*args, "--env", "NavigationCopy-v0", *ENV_ARGS[:4], "--out", str(tmp_path / "c")]) == 0
    assert "note: the model was trained on Navigation-v0" in capsys.readouterr().err
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    assert summary["env"] == "NavigationCopy-v0" and summary["config"]["n_robots"] == 2


def test_unreadable_sidecar_is_a_usage_error(run, tmp_path, capsys):
    shutil.copy(run["out"], tmp_path / "m.zip")
    (tmp_path / "m.json").write_text("{not json")
    assert evaluate_main(["--policy", f"sb3:{tmp_path / 'm.zip'}", "--out", str(tmp_path / "x"), "--quiet"]) == 2
    one_line_error(capsys.readouterr().err, "cannot read the model's sidecar")


def test_stochastic_evaluation(run, tmp_path, capsys):
    model = f"sb3:{run['out']}"
    stochastic = {"deterministic": False}
    first = evaluate("Navigation-v0", model, episodes=2, seed=3, config=OVERRIDES, policy_kwargs=stochastic)
    again = evaluate("Navigation-v0", model, episodes=2, seed=3, config=OVERRIDES, policy_kwargs=stochastic)
    greedy = evaluate("Navigation-v0", model, episodes=2, seed=3, config=OVERRIDES)
    assert first == again  # each episode reseeds the generators SB3 samples from
    assert [r.returns for r in first] != [r.returns for r in greedy]
    args = ["--policy", model, "--episodes", "2", "--seed", "3", "--stochastic", "--out", str(tmp_path / "s"), "--quiet"]
    assert evaluate_main(args) == 0
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["deterministic"] is False
    assert summary["mean_return"] == pytest.approx(summarise(first)["mean_return"])
    assert evaluate_main(["--policy", "goto", "--stochastic", "--out", str(tmp_path / "g"), "--quiet"]) == 2
    one_line_error(capsys.readouterr().err, "--stochastic applies to learned policies (sb3:PATH, rllib:PATH) only")


# -- several seeds -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def seeds_run(tmp_path_factory):
    directory = tmp_path_factory.mktemp("seeds") / "nav_ppo"
    args = ["--seeds", "0,1", "--timesteps", "64", *ENV_ARGS, *PPO_ARGS, "--eval-every", "64", "--eval-episodes", "2"]
    return train_main([*args, "--out", str(directory)]), directory


def test_seeds_train_one_model_per_seed(seeds_run):
    code, directory = seeds_run
    assert code == 0
    manifest = json.loads((directory / "runs.json").read_text())
    assert manifest["seeds"] == [0, 1]
    for seed in (0, 1):
        model = directory / f"seed{seed}" / "Navigation-v0_ppo.zip"
        assert manifest["models"][str(seed)] == str(model)
        meta = json.loads(model.with_suffix(".json").read_text())
        assert meta["seed"] == seed and meta["trained_timesteps"] == 64 and meta["eval"]["seed"] == 10_000
        rows = read_rows(directory / f"seed{seed}" / "Navigation-v0_ppo_eval.csv")
        assert [int(r["timesteps"]) for r in rows] == [0, 64]
    a, b = (weights(directory / f"seed{s}" / "Navigation-v0_ppo.zip") for s in (0, 1))
    assert any(not np.array_equal(a[k], b[k]) for k in a)


def test_seeds_in_parallel_processes(tmp_path, capsys):
    args = ["--seeds", "2,3", "--jobs", "2", "--timesteps", "64", *ENV_ARGS, *PPO_ARGS, "--out", str(tmp_path)]
    assert train_main(args) == 0
    printed = capsys.readouterr().out
    for seed in (2, 3):
        model = tmp_path / f"seed{seed}" / "Navigation-v0_ppo.zip"
        assert f"seed {seed}: saved {model}" in printed
        assert json.loads(model.with_suffix(".json").read_text())["seed"] == seed
        assert (tmp_path / f"seed{seed}" / "train.log").is_file()
    sequential = train(timesteps=64, seed=2, out=tmp_path / "again.zip", **TRAIN_KWARGS)
    a, b = weights(sequential), weights(tmp_path / "seed2" / "Navigation-v0_ppo.zip")
    assert all(np.array_equal(a[k], b[k]) for k in a)  # a worker process trains exactly as in-process


# -- learning curves -------------------------------------------------------------------------


def write_eval_csv(path: Path, timesteps: list[int], success: list[float], returns: list[float] | None = None) -> Path:
    log = EvalLog(path)
    for i, (t, s) in enumerate(zip(timesteps, success)):
        log.append(t, {"success_rate": s, "mean_return": (returns or success)[i], "mean_episode_length": 10.0})
    return path


@pytest.fixture
def synthetic_runs(tmp_path):
    finals = [0.2, 0.5, 0.6]
    for seed, final in enumerate(finals):
        write_eval_csv(tmp_path / "runA" / f"seed{seed}" / "m_eval.csv", [0, 100, 200], [0.0, final / 2, final])
    write_eval_csv(tmp_path / "runB" / "m_eval.csv", [0, 150, 250], [0.0, 0.3, 0.9])
    return tmp_path, finals


def test_curve_statistics(synthetic_runs):
    from scipy.stats import t as student

    root, finals = synthetic_runs
    groups = plot_curves.group_runs([root / "runA" / "seed0", root / "runA" / "seed1", root / "runA" / "seed2"])
    assert list(groups) == ["runA"] and len(groups["runA"]) == 3  # seed<k> directories join their parent's curve
    assert plot_curves.group_runs([root / "runA"]) == groups
    write_eval_csv(root / "other" / "runA" / "m_eval.csv", [0, 100], [0.0, 1.0])
    assert set(plot_curves.group_runs([root / "runA", root / "other" / "runA"])) == {
        str((root / "runA").resolve()),
        str((root / "other" / "runA").resolve()),
    }  # curves whose directories share a name are labelled by path
    (curve,) = plot_curves.load_curves(groups, "success_rate")
    assert curve.timesteps.tolist() == [0, 100, 200] and curve.finals.tolist() == finals
    low, high = plot_curves.confidence_band(curve.values, "t")
    half = student.ppf(0.975, 2) * np.std(finals, ddof=1) / math.sqrt(3)
    assert low[-1] == pytest.approx(np.mean(finals) - half) and high[-1] == pytest.approx(np.mean(finals) + half)
    assert low[0] == high[0] == 0.0  # no spread at the start
    blow, bhigh = plot_curves.confidence_band(curve.values, "bootstrap")
    assert min(finals) <= blow[-1] <= np.mean(finals) <= bhigh[-1] <= max(finals)
    assert plot_curves.interquartile_mean([1, 2, 3, 4, 100, 5, 6, 7]) == pytest.approx(4.5)  # the middle 4 of 8
    assert plot_curves.interquartile_mean(finals) == pytest.approx((0.2 + 4 * 0.5 + 0.6) / 6)  # 3 seeds: [0.25, 0.75] of them
    # seeds evaluated at different timesteps are interpolated on the range they share
    t, values = plot_curves.aggregate(
        [(np.array([0.0, 100, 200]), np.array([0.0, 1, 2])), (np.array([0.0, 150]), np.array([0.0, 3]))]
    )
    assert t.tolist() == [0, 100, 150] and values.tolist() == [[0, 1, 1.5], [0, 2, 3]]


def test_plot_curves_cli_with_a_baseline_summary(synthetic_runs, capsys):
    root, finals = synthetic_runs
    summary = root / "goto" / "summary.json"
    summary.parent.mkdir()
    summary.write_text(json.dumps({"env": "Navigation-v0", "seed": 10_000, "episodes": 10, "success_rate": 0.75}))
    out = root / "curve.png"
    args = [str(root / "runA"), str(root / "runB"), "--baseline", f"goto={summary}", "--out", str(out)]
    assert plot_curves.main(args) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    lines = {line.split()[0]: line for line in printed.splitlines() if line and not line.startswith("-")}
    assert "IQM" in lines["run"]
    assert f"{np.mean(finals):.3g}" in lines["runA"] and "0.2 0.5 0.6" in lines["runA"]
    assert lines["runB"].split()[1:4] == ["1", "250", "0.9"]
    assert "0.75" in lines["goto"]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["nowhere"], "no such run directory"),
        (["runA", "--metric", "bogus"], "has no column 'bogus'"),
        (["runA", "--baseline", "goto"], "no model sidecar"),
        (["runA", "--baseline", "goto=missing.json"], "cannot read --baseline goto's summary"),
        (["runA", "--ci", "normal"], "--ci"),
    ],
)
def test_plot_curves_usage_errors(args, needle, synthetic_runs, capsys, monkeypatch):
    root, _ = synthetic_runs
    monkeypatch.chdir(root)
    assert plot_curves.main([*args, "--out", str(root / "c.png")]) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not (root / "c.png").exists()


def test_plot_curves_computes_baselines_on_the_runs_held_out_seeds(seeds_run, tmp_path, capsys):
    _, directory = seeds_run
    out = tmp_path / "curve.png"
    assert plot_curves.main([str(directory), "--baseline", "random", "--metric", "mean_return", "--out", str(out)]) == 0
    expected = summarise(evaluate("Navigation-v0", "random", episodes=2, seed=10_000, config=OVERRIDES))["mean_return"]
    random_line = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("random"))
    assert f"{expected:.3g}" in random_line and "seeds 10000..10001" in random_line
    assert out.is_file()
