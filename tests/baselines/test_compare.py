"""``baselines.rl.compare`` (scripted vs learned tables) and shipped agents loaded by name."""

from __future__ import annotations

import json

import numpy as np
import pytest

from baselines.episode import EpisodeResult
from baselines.rl import compare as compare_module
from baselines.rl.compare import compare, main, markdown, row_of


def result(seed, success, collisions, arrivals, path=1.0, length=50):
    metrics = {
        f"robot_{i}": {"collisions": c, "path_length": path, **({"time_to_goal": t} if t is not None else {})}
        for i, (c, t) in enumerate(zip(collisions, arrivals))
    }
    return EpisodeResult(seed=seed, length=length, success=success, returns={a: 0.0 for a in metrics}, metrics=metrics)


def test_row_statistics():
    results = [
        result(0, True, [0, 0], [3.0, 5.0]),
        result(1, True, [1, 0], [4.0, 6.0]),
        result(2, False, [0, 2], [None, 7.0]),
        result(3, True, [0, 0], [2.0, 2.0]),
    ]
    row = row_of("x", "goto", results, dt=0.1)
    assert row["success"] == 0.75 and row["clean_success"] == 0.5
    assert row["success_ci"][0] < 0.75 < row["success_ci"][1]
    assert row["time_to_success"]["mean"] == pytest.approx((5 + 6 + 2) / 3)  # the last robot's arrival
    assert row["collisions"]["mean"] == pytest.approx((0 + 0.5 + 1 + 0) / 4)
    no_times = row_of("y", "p", [result(0, True, [0], [None], length=40)], dt=0.1)
    assert no_times["time_to_success"]["mean"] == pytest.approx(4.0)  # length × dt
    assert "| y | 100 % [21, 100] | 100 % [21, 100] | 4.0 |" in markdown([no_times])
    # Macro actions: length counts decisions; the env's reported time is the time to success.
    explored = EpisodeResult(0, 23, True, {"a": 0.0, "b": 0.0}, {"a": {"explore_time": 17.5}, "b": {"explore_time": 17.5}})
    assert row_of("z", "p", [explored], dt=0.1)["time_to_success"]["mean"] == pytest.approx(17.5)


def test_compare_runs_every_policy_on_the_same_seeds(monkeypatch):
    seen = []
    from baselines import evaluate as evaluate_module

    real = evaluate_module.evaluate

    def spy(env_id, policy, episodes, seed, config, workers):
        seen.append((policy, seed, episodes, dict(config)))
        return real(env_id, policy, episodes=episodes, seed=seed, config=config, workers=workers)

    monkeypatch.setattr(evaluate_module, "evaluate", spy)
    rows = compare("Navigation-v0", None, episodes=2, seed=30, task={"max_cycles": 30})
    assert [r["label"] for r in rows] == [label for label, _ in compare_module.SCRIPTED["Navigation-v0"]]
    assert {(s, e) for _, s, e, _ in seen} == {(30, 2)}
    nash_config = next(c for p, _, _, c in seen if p == "nash")
    assert nash_config["action_type"] == "heading" and nash_config["max_cycles"] == 30
    assert all(r["episodes"] == 2 for r in rows)


def test_agent_rows_use_the_agents_config_and_shipped_names(tmp_path, monkeypatch, capsys):
    pytest.importorskip("stable_baselines3")
    from baselines.rl import sb3_policy
    from baselines.rl.train import train

    config = {"n_robots": 2, "n_obstacles": 0, "max_cycles": 20, "normalize_actions": True}
    model = train(
        "Navigation-v0",
        "ppo",
        timesteps=64,
        out=tmp_path / "tiny.zip",
        config=config,
        n_envs=1,
        hyperparameters={"n_steps": 32, "batch_size": 32},
    )
    monkeypatch.setattr(sb3_policy, "AGENT_DIR", tmp_path)
    assert sb3_policy.shipped_agents() == ["tiny"]
    assert sb3_policy.resolve_model("tiny") == tmp_path / "tiny.zip"
    with pytest.raises(FileNotFoundError, match="shipped agents: tiny"):
        sb3_policy.resolve_model("nope")
    rows = compare(
        "Navigation-v0",
        "tiny",
        episodes=2,
        seed=40,
        task={"n_robots": 2, "n_obstacles": 0, "max_cycles": 20},
        policies=[("goto", "goto"), ("random", "random")],
    )
    assert [r["label"] for r in rows] == ["goto", "trained: tiny", "random"]
    assert model.is_file()
    assert (
        main(
            [
                "--env",
                "Navigation-v0",
                "--agent",
                "tiny",
                "--episodes",
                "1",
                "--set",
                "n_robots=2",
                "--set",
                "n_obstacles=0",
                "--set",
                "max_cycles=20",
                "--out",
                str(tmp_path / "cmp"),
            ]
        )
        == 0
    )
    record = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert [r["label"] for r in record["rows"]][-2:] == ["trained: tiny", "random"]
    assert "| trained: tiny |" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--episodes", "0"], "--episodes"),
        (["--agent", "no-such-agent"], "no saved SB3 model"),
        (["--curve"], "--curve needs"),
        (["--env", "Nope-v0"], "unknown env id 'Nope-v0'"),
        (["--set", "bogus=1"], "unknown config key(s) ['bogus']"),
    ],
)
def test_usage_errors_are_one_line(args, needle, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1 and "Traceback" not in err


def test_wrong_env_agent_is_refused(tmp_path, monkeypatch):
    from baselines.rl import sb3_policy

    (tmp_path / "m.zip").write_bytes(b"")
    (tmp_path / "m.json").write_text(json.dumps({"env": "Exploration-v0", "config": {}}))
    monkeypatch.setattr(sb3_policy, "AGENT_DIR", tmp_path)
    with pytest.raises(ValueError, match="trained on Exploration-v0"):
        compare("Navigation-v0", "m", episodes=1)


@pytest.mark.parametrize("metric", ["success_rate", "mean_collisions"])
def test_learning_curve_of_any_metric_with_the_scripted_rows_as_lines(tmp_path, monkeypatch, metric):
    pytest.importorskip("matplotlib")
    from baselines.rl import plot_curves, sb3_policy

    (tmp_path / "agent.zip").write_bytes(b"not read")
    (tmp_path / "agent_eval.csv").write_text("timesteps,success_rate,mean_collisions\n0,0.5,0.9\n100,1.0,0.3\n")
    monkeypatch.setattr(sb3_policy, "AGENT_DIR", tmp_path)
    drawn = {}
    monkeypatch.setattr(
        plot_curves, "plot_curves", lambda curves, path, m, lines, title: drawn.update(m=m, lines=lines, y=curves)
    )
    rows = [
        {"label": "goto", "policy": "goto", "success": 1.0, "collisions": {"mean": 0.65}, "path_length": {"mean": 1.2}},
        {"label": "trained", "policy": "sb3:x", "success": 1.0, "collisions": {"mean": 0.1}, "path_length": {"mean": 1.0}},
    ]
    compare_module._curve("agent", rows, tmp_path, metric)
    assert drawn["m"] == metric
    assert drawn["lines"] == [("goto", 1.0 if metric == "success_rate" else 0.65, "")]
    assert np.allclose(np.ravel(drawn["y"][0].values), [0.5, 1.0] if metric == "success_rate" else [0.9, 0.3])


def fake_agent(tmp_path, monkeypatch, name: str, sidecar: dict) -> dict:
    """A shipped agent ``name`` with ``sidecar`` (its zip never read) and an ``evaluate`` that records each
    row's config instead of playing; returns the record (policy -> config)."""
    from baselines import evaluate as evaluate_module
    from baselines.rl import sb3_policy

    (tmp_path / f"{name}.zip").write_bytes(b"not read")
    (tmp_path / f"{name}.json").write_text(json.dumps(sidecar))
    monkeypatch.setattr(sb3_policy, "AGENT_DIR", tmp_path)
    seen = {}

    def spy(env_id, policy, episodes, seed, config, workers):
        seen[policy] = dict(config)
        return [EpisodeResult(seed, 5, False, {"robot_0": 0.0}, {"robot_0": {}})]

    monkeypatch.setattr(evaluate_module, "evaluate", spy)
    return seen


def test_agent_config_is_its_training_overrides_so_a_task_option_can_change(tmp_path, monkeypatch):
    sidecar = {
        "env": "BoxPushing-v0",
        "config": {"situation": "S1", "n_robots": 1, "n_light_boxes": 1, "n_heavy_boxes": 0, "action_type": "primitives"},
        "overrides": {"situation": "S1", "action_type": "primitives"},
    }
    seen = fake_agent(tmp_path, monkeypatch, "s1agent", sidecar)
    compare("BoxPushing-v0", "s1agent", episodes=1, task={"situation": "S3"}, policies=[])
    (config,) = seen.values()
    assert config == {"situation": "S3", "action_type": "primitives"}  # no S1 robot count left to contradict S3


def test_an_agent_trained_on_another_team_size_needs_the_task_given(tmp_path, monkeypatch):
    sidecar = {"env": "Foraging-v0", "config": {"n_robots": 8}, "overrides": {"n_robots": 8, "observe_novelty": True}}
    seen = fake_agent(tmp_path, monkeypatch, "eight", sidecar)
    with pytest.raises(ValueError, match=r"plays 8 robots .*n_robots=8.* scripted rows 2: give the task's settings with --set"):
        compare("Foraging-v0", "eight", episodes=1, policies=[("dmaps", "dmaps")])
    assert seen == {}  # refused before any episode
    compare("Foraging-v0", "eight", episodes=1, task={"n_robots": 8}, policies=[("dmaps", "dmaps")])
    assert seen["dmaps"]["n_robots"] == 8 and all(config["n_robots"] == 8 for config in seen.values()) and len(seen) == 2


def test_the_cli_refuses_a_shipped_s3_agent_without_its_situation_in_one_line(capsys):
    assert main(["--env", "BoxPushing-v0", "--agent", "boxpushing-s3-ppo", "--episodes", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plays 4 robots" in err[0] and "situation=S3" in err[0] and "scripted rows 2" in err[0]
