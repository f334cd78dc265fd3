"""``python -m baselines.rl.seeds``: a ``--seeds`` run evaluated seed by seed through ``compare``, the figures
across seeds, the median seed, ``--ship`` and the learning curve across seeds.

The run is tiny: three seeds of PPO for 64 timesteps on Navigation-v0 with two robots and 10-step
episodes, evaluated during training on seeds 10000-10001; 3 held-out episodes per seed here.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from baselines.evaluate import evaluate  # noqa: E402
from baselines.learned import check_sidecar, read_sidecar  # noqa: E402
from baselines.rl import plot_curves  # noqa: E402
from baselines.rl.compare import compare, episode_values, row_of  # noqa: E402
from baselines.rl.seeds import evaluate_seeds, main, median_seed, read_runs  # noqa: E402
from baselines.seed_stats import iqm  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

TRAIN = ["--timesteps", "64", "--set", "n_robots=2", "--max-cycles", "10", "--n-envs", "1", "--verbose", "0"]
TRAIN += ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=2", "--eval-every", "64", "--eval-episodes", "2"]
HELD_OUT = ["--episodes", "3", "--seed", "31000", "--resamples", "200"]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("seeds") / "nav"
    assert train_main(["--seeds", "0,1,2", *TRAIN, "--out", str(directory)]) == 0
    return directory


@pytest.fixture
def fresh_run(run_dir, tmp_path):
    """A copy of the run that a test may write into."""
    copy = tmp_path / "nav"
    shutil.copytree(run_dir, copy)
    return copy


def one_line_error(err: str, needle: str) -> None:
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert needle in err, err


def test_each_seed_is_the_compare_row_of_its_model(run_dir):
    record = evaluate_seeds(run_dir, episodes=3, seed=31000, metric="path_length", resamples=200)
    assert record["env"] == "Navigation-v0" and record["seeds"] == [0, 1, 2]
    assert record["held_out"] == {"seed": 31000, "episodes": 3}
    for s in (0, 1, 2):
        model = run_dir / f"seed{s}" / "Navigation-v0_ppo.zip"
        (direct,) = compare("Navigation-v0", str(model), episodes=3, seed=31000, policies=[])
        assert record["per_seed"][str(s)] == {**direct, "label": f"seed {s}"}  # the same episodes, the same numbers
    for name, stats in record["across_seeds"].items():
        rows = [record["per_seed"][str(s)] for s in (0, 1, 2)]
        if name in ("success", "clean_success"):
            expected = [row[name] for row in rows]  # the seed's rate
        else:
            expected = [(row["metrics"][name] if name in row["metrics"] else row[name])["mean"] for row in rows]
        assert stats["per_run"] == pytest.approx(expected), name
        assert stats["iqm"] == pytest.approx(iqm(stats["per_run"]))
        assert stats["iqm_ci"][0] <= stats["iqm"] <= stats["iqm_ci"][1]
    paths = {s: record["across_seeds"]["path_length"]["per_run"][s] for s in (0, 1, 2)}
    assert record["median_seed"] == sorted(paths, key=lambda s: (-paths[s], -s))[1]  # the middle of worst to best
    assert record["across_seeds"]["success"]["optimality_gap"] == pytest.approx(1 - record["across_seeds"]["success"]["mean"])


def test_episode_values_are_what_rows_are_made_of(run_dir):
    model = f"sb3:{run_dir / 'seed0' / 'Navigation-v0_ppo.zip'}"
    results = evaluate("Navigation-v0", model, episodes=3, seed=31000, config={"n_robots": "2", "max_cycles": "10"})
    row = row_of("m", model, results, 0.1, ("min_clearance",))
    values = episode_values(results, 0.1, ("min_clearance",))
    assert np.mean(values["success"]) == row["success"] and np.mean(values["clean_success"]) == row["clean_success"]
    for name in ("path_length", "collisions"):
        assert np.mean(values[name]) == pytest.approx(row[name]["mean"]) and len(values[name]) == row[name]["n"]
    assert np.mean(values["min_clearance"]) == pytest.approx(row["metrics"]["min_clearance"]["mean"])
    assert len(values["time_to_success"]) == row["time_to_success"]["n"]


def test_median_seed_by_hand():
    scores = {0: {"success": 0.9}, 1: {"success": 0.5}, 2: {"success": 0.7}}
    assert median_seed(scores) == 2
    scores[3] = {"success": 1.0}
    assert median_seed(scores) == 2  # an even count: the worse of the middle two
    times = {0: {"time_to_success": 9.0}, 1: {"time_to_success": None}, 2: {"time_to_success": 5.0}}
    assert median_seed(times, "time_to_success") == 0  # lower is better; no time counts as the worst
    ties = {0: {"success": 1.0, "time_to_success": 4.0}, 1: {"success": 1.0, "time_to_success": 6.0}, 2: {"success": 1.0}}
    assert median_seed(ties) == 1  # ties go to the time to success
    assert median_seed({5: {"success": 0.2}}) == 5
    with pytest.raises(ValueError, match="unknown metric 'bogus'"):
        median_seed(scores, "bogus")


def test_cli_writes_the_record_and_ships_the_median_seed(fresh_run, tmp_path, capsys):
    agents = tmp_path / "agents"
    assert main([str(fresh_run), *HELD_OUT, "--curve", "--ship", "tiny-ppo", "--agents-dir", str(agents)]) == 0
    printed = capsys.readouterr().out
    record = json.loads((fresh_run / "seeds.json").read_text())
    median = record["median_seed"]
    assert f"| seed {median} (median) |" in (fresh_run / "seeds.md").read_text() and "| success |" in printed
    assert (fresh_run / "curve.png").read_bytes()[:4] == b"\x89PNG"
    source = fresh_run / f"seed{median}" / "Navigation-v0_ppo.zip"
    assert (agents / "tiny-ppo.zip").read_bytes() == source.read_bytes()
    assert (agents / "tiny-ppo_eval.csv").read_text() == (fresh_run / f"seed{median}" / "Navigation-v0_ppo_eval.csv").read_text()
    sidecar = read_sidecar("sb3", agents / "tiny-ppo.zip")
    assert sidecar["seed"] == median and sidecar["model"] == "tiny-ppo.zip" and sidecar["eval"]["csv"] == "tiny-ppo_eval.csv"
    assert sidecar["seeds"]["median_seed"] == median and sidecar["seeds"]["seeds"] == [0, 1, 2]
    assert sidecar["seeds"]["across_seeds"]["success"]["iqm"] == record["across_seeds"]["success"]["iqm"]
    # the shipped copy plays as the median seed did (the env and config come from its sidecar)
    shipped = evaluate("Navigation-v0", f"sb3:{agents / 'tiny-ppo.zip'}", episodes=3, seed=31000, config=sidecar["overrides"])
    assert row_of("x", "x", shipped, 0.1)["path_length"] == record["per_seed"][str(median)]["path_length"]
    # shipping again needs --force
    assert main([str(fresh_run), *HELD_OUT, "--ship", "tiny-ppo", "--agents-dir", str(agents)]) == 2
    one_line_error(capsys.readouterr().err, "exists; give --force")


def test_best_models_and_a_moved_run_directory(fresh_run, tmp_path):
    moved = tmp_path / "elsewhere"
    fresh_run.rename(moved)  # runs.json names the old paths; the models are found in seed<k>/
    assert [p.name for p in read_runs(moved, "best").values()] == ["Navigation-v0_ppo_best.zip"] * 3
    assert read_runs(moved)[1] == moved / "seed1" / "Navigation-v0_ppo.zip"


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["{missing}"], "no runs.json"),
        (["{run}", "--seed", "9999", "--episodes", "2"], "overlap seed 0's evaluation seeds during training 10000..10001"),
        (["{run}", "--force"], "--agents-dir and --force apply to --ship only"),
        (["{run}", "--curve-metric", "mean_return"], "--curve-metric applies to --curve only"),
        (["{run}", "--curve", "--curve-metric", "bogus"], "has no column 'bogus'"),
        (["{run}", "--ship", "../x", "--agents-dir", "{tmp}"], "--ship expects an agent name"),
        (["{run}", "--set", "n_robots=-1"], "n_robots"),
        (["{run}", "--model", "latest"], "--model"),
        (["{run}", "--episodes", "0"], "--episodes"),
        (["{nocurve}", "--ship", "x", "--agents-dir", "{tmp}"], "--ship needs every seed's learning curve"),
        (["{badmanifest}"], "runs.json': it has no field 'models'"),
    ],
)
def test_bad_input_is_one_line_before_any_episode(args, needle, fresh_run, tmp_path, capsys):
    nocurve = tmp_path / "nocurve"
    shutil.copytree(fresh_run, nocurve)
    (nocurve / "seed2" / "Navigation-v0_ppo_eval.csv").unlink()
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "runs.json").write_text('{"seeds": [0]}')
    names = {"missing": tmp_path / "none", "run": fresh_run, "tmp": tmp_path / "agents", "nocurve": nocurve, "badmanifest": bad}
    assert main([a.format(**names) for a in args]) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not (fresh_run / "seeds.json").exists() and not (tmp_path / "agents").exists()


def test_sidecar_seeds_field_is_checked():
    base = {"env": "Navigation-v0", "algo": "ppo"}
    ok = check_sidecar({**base, "seeds": {"seeds": [0, 1, 2], "median_seed": 1, "across_seeds": {}}}, "sb3", Path("a.json"))
    assert ok["seeds"]["median_seed"] == 1
    assert "seeds" not in check_sidecar(base, "sb3", Path("a.json"))  # a sidecar without it reads as before
    for bad, needle in [
        ([0, 1], "field 'seeds' must be an object"),
        ({"seeds": [], "median_seed": 0}, "field 'seeds.seeds' must be a non-empty list of integers"),
        ({"seeds": [0, 1], "median_seed": 2}, "field 'seeds.median_seed' must be one of seeds.seeds"),
        ({"seeds": [0, 1], "median_seed": True}, "field 'seeds.median_seed'"),
    ]:
        with pytest.raises(ValueError, match=needle.replace(".", r"\.")):
            check_sidecar({**base, "seeds": bad}, "sb3", Path("a.json"))


def test_learning_curve_across_seeds_iqm_and_min_max(run_dir, tmp_path, capsys):
    groups = plot_curves.group_runs([run_dir])
    (curve,) = plot_curves.load_curves(groups, "mean_return")
    assert curve.values.shape[0] == 3
    line = plot_curves.centre_line(curve.values, "iqm")
    assert line.tolist() == pytest.approx([iqm(curve.values[:, j]) for j in range(curve.values.shape[1])])
    low, high = plot_curves.confidence_band(curve.values, "minmax", center="iqm")
    assert low.tolist() == curve.values.min(axis=0).tolist() and high.tolist() == curve.values.max(axis=0).tolist()
    blow, bhigh = plot_curves.confidence_band(curve.values, "bootstrap", center="iqm")
    # A percentile bootstrap of the IQM lies within the seeds' range; with 3 seeds it need not hold the IQM itself.
    # (up to rounding: the IQM of a resample of one repeated value may differ from it in the last bit)
    tol = 1e-12 * (1.0 + np.abs(curve.values).max())
    assert np.all(low - tol <= blow) and np.all(blow <= bhigh) and np.all(bhigh <= high + tol)
    assert np.all(low - tol <= line) and np.all(line <= high + tol)
    out = tmp_path / "c.png"
    assert (
        plot_curves.main([str(run_dir), "--metric", "mean_return", "--center", "iqm", "--ci", "minmax", "--out", str(out)]) == 0
    )
    assert "min-max" in capsys.readouterr().out and out.is_file()
    assert plot_curves.main([str(run_dir), "--center", "iqm", "--ci", "t", "--out", str(tmp_path / "d.png")]) == 2
    one_line_error(capsys.readouterr().err, "--ci t is an interval of the mean")


def test_compare_with_a_run_directory_shows_the_median_seed_and_the_figures_across_seeds(run_dir, tmp_path, capsys):
    from baselines.rl.compare import main as compare_main

    out = tmp_path / "cmp"
    args = ["--agent", str(run_dir), "--episodes", "3", "--seed", "31000", "--set", "n_robots=2", "--set", "max_cycles=10"]
    assert compare_main([*args, "--out", str(out), "--curve"]) == 0
    assert "across 3 seeds (IQM [95 % bootstrap CI]): success 0 %" in capsys.readouterr().out
    assert (out / "curve.png").is_file()
    saved = {r["label"]: r for r in json.loads((out / "comparison.json").read_text())["rows"]}
    rows = compare("Navigation-v0", str(run_dir), 3, 31000, task={"n_robots": "2", "max_cycles": "10"}, policies=[])
    (learned,) = rows
    median = int(learned["label"].split("(seed ")[1].split(",")[0])
    assert learned["label"] == f"trained: {run_dir} (seed {median}, the median of 3)"
    assert learned["policy"] == f"sb3:{run_dir / f'seed{median}' / 'Navigation-v0_ppo.zip'}"
    assert saved[learned["label"]]["across_seeds"]["path_length"] == learned["across_seeds"]["path_length"]  # reproducible
    per_run = learned["across_seeds"]["path_length"]["per_run"]
    assert learned["path_length"]["mean"] == pytest.approx(per_run[median])  # the row is the median seed's
    assert sum(r.get("across_seeds") is not None for r in saved.values()) == 1  # the scripted rows have none
    assert compare_main(["--agent", str(tmp_path), "--episodes", "2"]) == 2  # neither a model nor a run directory
    one_line_error(capsys.readouterr().err, "no saved SB3 model")
