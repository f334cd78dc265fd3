"""Tests of ``baselines.evaluate``: the CLI end to end, parallel workers, error messages."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import teamgym
from baselines import make_policy
from baselines.episode import Step, success_of
from baselines.evaluate import EpisodeResult, evaluate, main, run_episode
from baselines.summary import summarise, summary_table

REPO = Path(__file__).resolve().parents[2]
SHORT = ["--set", "max_cycles=30"]


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run(
        [sys.executable, "-m", "baselines.evaluate", *args], capture_output=True, text=True, cwd=cwd or REPO, env=env, timeout=120
    )


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open() as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory) -> tuple[subprocess.CompletedProcess, Path]:
    out = tmp_path_factory.mktemp("eval") / "run"
    proc = run_cli("--episodes", "2", "--seed", "5", *SHORT, "--out", str(out), "--gif")
    return proc, out


def test_cli_end_to_end(cli_run):
    proc, out = cli_run
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    for key in ("env", "policy", "config", "episodes", "seed", "success_rate", "mean_episode_length", "mean_return", "metrics"):
        assert key in summary
    assert summary["env"] == "Navigation-v0"
    assert summary["policy"] == "goto"
    assert summary["episodes"] == 2
    assert summary["seed"] == 5
    assert summary["config"]["max_cycles"] == 30
    for metric in ("arrived", "distance_to_goal", "path_length", "collisions", "min_clearance", "smoothness"):
        assert f"mean_{metric}" in summary

    rows = read_csv(out / "episodes.csv")
    assert [int(r["seed"]) for r in rows] == [5, 6]
    lengths = [int(r["length"]) for r in rows]
    assert all(1 <= n <= 30 for n in lengths)
    assert summary["mean_episode_length"] == pytest.approx(np.mean(lengths))
    assert summary["success_rate"] == pytest.approx(np.mean([int(r["success"]) for r in rows]))
    # Metrics every robot reports: pooled mean == mean of per-episode means (equal team sizes).
    for metric in ("distance_to_goal", "path_length", "collisions", "arrived"):
        assert summary[f"mean_{metric}"] == pytest.approx(np.mean([float(r[metric]) for r in rows]))
    assert summary["mean_return"] == pytest.approx(np.mean([float(r["return"]) for r in rows]))

    assert (out / "trajectories.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "episode.gif").read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert "success_rate" in proc.stdout and "path_length" in proc.stdout


def test_cli_workers_match_sequential(cli_run, tmp_path):
    _, out1 = cli_run
    proc = run_cli("--episodes", "2", "--seed", "5", *SHORT, "--out", str(tmp_path), "--workers", "2", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert read_csv(tmp_path / "episodes.csv") == read_csv(out1 / "episodes.csv")
    s1 = json.loads((out1 / "summary.json").read_text())
    s2 = json.loads((tmp_path / "summary.json").read_text())
    s1.pop("workers"), s2.pop("workers")
    assert s1 == s2


def test_evaluate_function_workers_identical():
    config = {"max_cycles": 15, "n_robots": 2}
    sequential = evaluate("Navigation-v0", "random", episodes=3, seed=11, config=config, workers=1)
    parallel = evaluate("Navigation-v0", "random", episodes=3, seed=11, config=config, workers=2)
    assert [r.seed for r in parallel] == [11, 12, 13]
    assert sequential == parallel
    assert sequential[0].trajectories is not None and parallel[0].trajectories is not None
    assert sequential[1].trajectories is None


def test_bad_set_key_exits_2_with_message():
    proc = run_cli("--set", "bogus_key=3", "--episodes", "1")
    assert proc.returncode == 2
    assert "bogus_key" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


@pytest.fixture
def no_episodes(monkeypatch):
    """Fail the test if the CLI gets as far as running an episode."""

    def refuse(*args, **kwargs):
        raise AssertionError("an episode ran although the command line is invalid")

    monkeypatch.setattr("baselines.evaluate.evaluate", refuse)
    monkeypatch.setattr("baselines.runners.run_episode", refuse)


def assert_one_line_error(err: str, needle: str) -> None:
    assert err.startswith("error: ")
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    assert needle in err


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--set", "n_robots=many"], "n_robots"),
        (["--set", "n_robots"], "key=value"),
        (["--env", "Nowhere-v0"], "unknown env id 'Nowhere-v0'"),
        (["--policy", "no_such_policy"], "unknown policy 'no_such_policy'"),
        (["--policy", "sb3:/no/such/model.zip"], "no saved SB3 model"),
        (["--episodes", "0"], "--episodes"),
        (["--episodes", "-3"], "--episodes"),
        (["--episodes", "many"], "--episodes"),
        (["--seed", "-1"], "--seed"),
        (["--workers", "0"], "--workers"),
        (["--env", "Exploration-v0", "--policy", "goto"], "policy 'goto' does not fit Exploration-v0"),
        (["--env", "Navigation-v0", "--policy", "greedy"], "policy 'greedy' does not fit Navigation-v0"),
        (["--env", "BoxPushing-v0", "--policy", "nash-first"], "policy 'nash-first' does not fit BoxPushing-v0"),
        (["--env", "Exploration-v0", "--policy", "sbs"], "policy 'sbs' does not fit Exploration-v0"),
        (["--env", "BoxPushing-v0", "--policy", "sbs", "--set", "action_type=wheels"], "primitives"),
        (["--policy-kwargs", "{bad"], "--policy-kwargs: expected a JSON object"),
        (["--policy-kwargs", "[1, 2]"], "expected a JSON object {...}, got list"),
        (["--policy", "goto", "--policy-kwargs", '{"speed": 1}'], "unexpected keyword argument 'speed'"),
        (["--policy", "goto", "--policy-kwargs", '{"deterministic": true}', "--stochastic"], "--stochastic applies"),
        (["--policy", "sb3:x.zip", "--policy-kwargs", '{"deterministic": true}', "--stochastic"], "not both"),
    ],
)
def test_usage_errors(args, needle, capsys, tmp_path, no_episodes):
    assert main([*args, "--out", str(tmp_path / "x"), "--quiet"]) == 2
    assert_one_line_error(capsys.readouterr().err, needle)
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("under", [False, True])
def test_out_naming_a_file_fails_before_any_episode(under, capsys, tmp_path, no_episodes):
    existing = tmp_path / "results.txt"
    existing.write_text("keep me")
    out = existing / "run" if under else existing
    assert main(["--episodes", "1", "--out", str(out), "--quiet"]) == 2
    assert_one_line_error(capsys.readouterr().err, str(existing))
    assert existing.read_text() == "keep me"


def test_policy_kwargs_reach_the_policy_and_the_summary(tmp_path):
    """``--policy-kwargs`` is the policy's keyword arguments: a slower cruise speed makes goto slower."""
    times = {}
    for cruise in (0.25, 0.1):
        out = tmp_path / str(cruise)
        args = ["--policy", "goto", "--episodes", "2", "--seed", "7", "--no-plot", "--quiet", "--out", str(out)]
        assert main([*args, "--policy-kwargs", json.dumps({"v_cruise": cruise})]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["policy_kwargs"] == {"v_cruise": cruise}
        times[cruise] = summary["mean_time_to_goal"]
    assert times[0.1] > times[0.25]


def test_negative_seed_from_the_shell_is_one_line():
    proc = run_cli("--seed", "-1", "--episodes", "1")
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "--seed")
    assert proc.stdout == ""


def test_failure_while_running_is_one_line_exit_1(monkeypatch, capsys, tmp_path):
    def crash(*args, **kwargs):
        raise RuntimeError("simulator exploded\nwith details")

    monkeypatch.delenv("TEAMGYM_TRACEBACK", raising=False)
    monkeypatch.setattr("baselines.evaluate.evaluate", crash)
    assert main(["--episodes", "1", "--out", str(tmp_path / "x"), "--quiet"]) == 1
    assert_one_line_error(capsys.readouterr().err, "RuntimeError: simulator exploded with details")
    monkeypatch.setenv("TEAMGYM_TRACEBACK", "1")
    with pytest.raises(RuntimeError, match="simulator exploded"):
        main(["--episodes", "1", "--out", str(tmp_path / "x"), "--quiet"])


def test_sb3_model_for_another_env_is_a_usage_error(capsys, tmp_path, no_episodes):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from baselines.rl.sb3_env import TeamVecEnv

    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", n_robots=2), n_envs=1)
    PPO("MlpPolicy", venv, n_steps=16, batch_size=16, device="cpu").save(str(tmp_path / "nav.zip"))
    args = ["--env", "BoxPushing-v0", "--policy", f"sb3:{tmp_path / 'nav.zip'}", "--out", str(tmp_path / "x")]
    assert main([*args, "--quiet"]) == 2
    assert_one_line_error(capsys.readouterr().err, "observations of shape")


def test_make_policy_rejects_a_policy_for_another_env():
    with pytest.raises(ValueError, match="policy 'goto' does not fit Exploration-v0: it is written for Navigation-v0"):
        make_policy("goto", teamgym.make("Exploration-v0"))
    with pytest.raises(ValueError, match="policy 'nash-explore' does not fit BoxPushing-v0"):
        make_policy("nash-explore", teamgym.make("BoxPushing-v0"))
    with pytest.raises(ValueError, match="policy 'goto' does not fit Exploration-v0"):
        evaluate("Exploration-v0", "goto", episodes=1)
    with pytest.raises(ValueError, match="seed must be >= 0"):
        evaluate("Navigation-v0", "goto", episodes=1, seed=-1)
    for env_id in teamgym.envs():  # random fits every env
        assert make_policy("random", teamgym.make(env_id)).env.possible_agents


def test_check_env_names_missing_observation_fields():
    from baselines.policy import Policy

    class NeedsLidar(Policy):
        name = "lidar"
        observation_fields = ("pose", "lidar", "map")

        def act(self, observations, infos=None):
            return {}

    env = teamgym.make("Navigation-v0")
    with pytest.raises(ValueError, match="policy 'lidar' does not fit Navigation-v0: .*lidar, map") as error:
        NeedsLidar.check_env(env)
    assert "pose" in str(error.value).split("they have:")[1]  # the fields it has are listed
    NeedsLidar.observation_fields = ("pose",)
    NeedsLidar.check_env(env)


def test_run_episode_collects_final_metrics():
    env = teamgym.make("Navigation-v0", max_cycles=200, n_obstacles=0)
    policy = make_policy("goto", env)
    result = run_episode(env, policy, seed=3)
    assert set(result.metrics) == set(env.possible_agents)
    assert result.length <= 200
    for metrics in result.metrics.values():
        assert ("time_to_goal" in metrics) == bool(metrics["arrived"])
    assert result.success == all(m["arrived"] for m in result.metrics.values())
    assert set(result.trajectories) == set(env.possible_agents)
    assert result.arena == (2.0, 2.0)
    assert set(result.goals) == set(env.possible_agents)
    again = run_episode(env, policy, seed=3)
    assert again == result


def test_run_episode_calls_the_hooks_after_reset_and_every_step():
    env = teamgym.make("Navigation-v0", n_robots=2, max_cycles=6)
    seen: list[tuple[int, tuple[str, ...], bool, bool]] = []

    def hook(step: Step) -> None:
        assert step.env is env and step.policy is policy
        assert set(step.actions) == (set() if step.index == 0 else set(step.agents))
        assert set(step.infos) == set(step.agents)
        seen.append((step.index, step.agents, step.done, step.success))

    policy = make_policy("goto", env)
    result = run_episode(env, policy, 1, on_step=hook, on_reset=hook)
    assert [index for index, *_ in seen] == list(range(result.length + 1))
    assert seen[0][1] == ("robot_0", "robot_1")
    assert [done for _, _, done, _ in seen] == [False] * result.length + [True]
    assert seen[-1][3] == result.success


def test_a_hook_may_change_the_episode():
    env = teamgym.make("BoxPushing-v0", situation="S2", max_cycles=8)
    acted: list[tuple[str, ...]] = []

    def remove_after_two_steps(step: Step) -> None:
        acted.append(step.agents)
        if step.index == 2:
            env.remove_robot("robot_1")  # it terminates in the next step's returns

    result = run_episode(env, make_policy("sbs", env), 0, on_step=remove_after_two_steps)
    assert acted[:3] == [("robot_0", "robot_1")] * 3
    assert all(agents == ("robot_0",) for agents in acted[3:]) and len(acted) == result.length == 8


def test_success_is_read_from_the_episode_contract():
    env = teamgym.make("Navigation-v0", max_cycles=3)
    policy = make_policy("goto", env)
    assert run_episode(env, policy, seed=0).success is False  # 3 steps cannot bring robots home
    env.episode_success = lambda: True
    result = run_episode(env, policy, seed=0)
    assert result.success is True
    assert all("success" not in metrics for metrics in result.metrics.values())  # the episode's, not a metric
    env.episode_success = lambda: env.cycles == 2  # only the last step counts
    assert run_episode(env, policy, seed=0).success is False


def test_agents_disagreeing_on_success_is_an_error():
    assert success_of({"a": {"success": True}, "b": {"success": True}}) is True
    assert success_of({"a": {"x": 1}}) is False  # an env outside the contract
    with pytest.raises(ValueError, match="disagree"):
        success_of({"a": {"success": True}, "b": {"success": False}})


def test_success_is_one_csv_column_not_a_metric(tmp_path):
    # BoxPushing-v0 also reports "success" among its own metrics: one CSV column, and the summary's
    # mean_success (which BoxPushing summaries always had) is the episode success rate.
    args = ["--env", "BoxPushing-v0", "--policy", "sbs", "--set", "situation=S1", "--max-cycles", "5", "--episodes", "2"]
    assert main([*args, "--out", str(tmp_path), "--quiet"]) == 0
    with (tmp_path / "episodes.csv").open() as handle:
        header = next(csv.reader(handle))
    assert header.count("success") == 1
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["success_rate"] == 0.0 and summary["mean_success"] == 0.0
    assert summary["metrics"]["success"]["count"] == 2


def test_summarise_pools_robots_and_episodes():
    a = EpisodeResult(0, 10, True, {"r0": 1.0, "r1": 3.0}, {"r0": {"arrived": True, "t": 2.0}, "r1": {"arrived": True, "t": 4.0}})
    b = EpisodeResult(1, 20, False, {"r0": 0.0, "r1": 0.0}, {"r0": {"arrived": True, "t": 6.0}, "r1": {"arrived": False}})
    summary = summarise([a, b])
    assert summary["success_rate"] == 0.5
    assert summary["mean_episode_length"] == 15
    assert summary["mean_return"] == 1.0
    assert summary["mean_arrived"] == pytest.approx(0.75)
    assert summary["mean_t"] == pytest.approx(4.0)  # only robots that report it
    assert summary["metrics"]["t"]["count"] == 3
    table = summary_table(summary, title="demo")
    lines = table.splitlines()
    assert lines[0] == "demo"
    mean_end = lines[1].index("mean") + len("mean")  # numeric columns are right-aligned under their header
    for line in lines[3:]:
        assert line[mean_end - 1] != " " and line[mean_end] == " "
    assert any(line.startswith("success_rate") for line in lines)


def test_non_finite_metrics_written_as_null(tmp_path):
    # One robot and no obstacles: min_clearance stays +inf; strict JSON has no Infinity.
    args = ["--set", "n_robots=1", "--set", "n_obstacles=0", "--max-cycles", "5", "--episodes", "1"]
    assert main([*args, "--out", str(tmp_path), "--quiet"]) == 0
    text = (tmp_path / "summary.json").read_text()
    assert "Infinity" not in text and "NaN" not in text
    summary = json.loads(text)
    assert summary["mean_min_clearance"] is None
    assert summary["config"]["n_robots"] == 1
    assert math.isinf(float(read_csv(tmp_path / "episodes.csv")[0]["min_clearance"]))


def test_policy_required_config_is_applied(tmp_path):
    out = tmp_path / "nash"
    result = run_cli(
        "--policy", "nash", "--episodes", "1", "--set", "n_robots=3", "--max-cycles", "40", "--out", str(out), "--quiet"
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["action_type"] == "heading"
    assert summary["policy"] == "nash" and summary["episodes"] == 1


def test_explicit_setting_overrides_required_config(tmp_path):
    result = run_cli("--policy", "nash", "--episodes", "1", "--set", "action_type=velocity", "--out", str(tmp_path), "--quiet")
    assert result.returncode == 2
    assert "heading" in result.stderr


def test_object_trails_follow_obstacles_and_boxes(tmp_path):
    from baselines.plots import plot_trajectories
    from teamgym.control.primitives import Primitive

    env = teamgym.make("Navigation-v0", n_robots=2, n_obstacles=2, max_cycles=10, obstacle_speed=0.2)
    result = run_episode(env, make_policy("goto", env), seed=4)
    assert set(result.object_paths) == {"obstacle_0", "obstacle_1"}
    for name, path in result.object_paths.items():
        assert len(path) == result.length + 1  # the reset position and one per step
        assert path[-1] == pytest.approx(env.world[name].position)
        # an obstacle covers at most speed × Δt per step (bounces and pushes only shorten it)
        hops = np.hypot(*np.diff(np.array(path), axis=0).T)
        assert hops.max() <= 0.2 * env.config.dt + 1e-6 and hops.sum() > 0
    png = plot_trajectories(result.trajectories, tmp_path / "t.png", arena=result.arena, objects=result.object_paths)
    assert png.stat().st_size > 0

    boxes = teamgym.make("BoxPushing-v0", situation="S1", n_spare_boxes=1)
    boxes.reset(seed=0)
    stop = int(Primitive.STOP)
    boxes.step({a: stop for a in boxes.agents})
    boxes.add_box(heavy=True)
    boxes.step({a: stop for a in boxes.agents})
    trails = boxes.object_trajectories()
    assert [len(t) for t in trails.values()] == [3, 1]


def test_chunks_cover_every_seed_in_order():
    from baselines.runners import chunks as split

    for n, workers in [(1, 2), (7, 2), (20, 2), (101, 4)]:
        chunks = split(list(range(n)), workers)
        assert [x for c in chunks for x in c] == list(range(n))
        assert len(chunks) <= 4 * workers and all(chunks)


def test_importing_baselines_loads_no_numpy_until_used():
    import subprocess
    import sys

    code = "import sys, baselines; assert 'numpy' not in sys.modules; baselines.make_policy; assert 'numpy' in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_summary_keeps_mean_success_equal_to_the_success_rate():
    from baselines.evaluate import evaluate
    from baselines.summary import summarise

    summary = summarise(evaluate("Navigation-v0", "goto", episodes=3, seed=0, config={"max_cycles": 60}))
    assert summary["mean_success"] == summary["success_rate"] and summary["metrics"]["success"]["count"] == 3
