"""experiments/paper001_navigation.py: workspaces of experiment 3, contact descriptions, CLI."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "paper001_navigation.py"


@pytest.fixture(scope="module")
def paper001():
    spec = importlib.util.spec_from_file_location("paper001_navigation", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_workspaces_are_the_documented_settings(paper001):
    assert paper001.WORKSPACES == {
        "walled": {"walls": True, "obstacle_motion": "bounce"},
        "open": {"walls": False, "obstacle_motion": "bounce"},
        "open-straight": {"walls": False, "obstacle_motion": "straight"},
    }
    assert paper001.OBSTACLE_SETTING == {"dt": 0.2, "robot_radius": 0.05, "n_obstacles": 2, "obstacle_speed": 0.2}


@pytest.mark.parametrize(
    ("vector", "heading", "expected"),
    [((1, 0), 0.0, 0.0), ((0, 1), 0.0, 90.0), ((0, -1), 0.0, -90.0), ((-1, 0), np.pi / 2, 90.0), ((1, 0), np.pi, 180.0)],
)
def test_relative_angle(paper001, vector, heading, expected):
    assert abs(paper001._relative_angle(np.array(vector, dtype=float), heading)) == pytest.approx(abs(expected), abs=1e-9)
    if abs(expected) != 180.0:
        assert paper001._relative_angle(np.array(vector, dtype=float), heading) == pytest.approx(expected, abs=1e-9)


def test_every_counted_collision_is_described(paper001):
    config = {**paper001.OBSTACLE_SETTING, **paper001.WORKSPACES["walled"], "n_robots": 5}
    result = paper001.run("Navigation-v0", "goto", 0, config)  # go-to-goal collides often
    assert result["collisions"] > 0
    assert result["success"] is False  # success with no contact: the paper's criterion
    assert isinstance(result["success"], bool)  # the env's, from infos
    assert len(result["contacts"]) == result["collisions"]
    for row in result["contacts"]:
        assert row["hit"] in {"obstacle", "robot", "wall"}
        assert ("bearing_deg" in row) == (row["hit"] == "obstacle")
        assert -180.0 <= row.get("bearing_deg", 0.0) <= 180.0
    assert result["outside_square_m"] == pytest.approx(0.0, abs=0.01)  # the walls keep the robots in


def test_open_workspace_records_obstacle_paths_and_exposure(paper001):
    config = {**paper001.OBSTACLE_SETTING, **paper001.WORKSPACES["open-straight"], "n_robots": 3}
    result = paper001.run("Navigation-v0", "nash", 0, config)
    paths = result["obstacle_paths"]
    assert paths.shape == (result["steps"], 2, 2)
    np.testing.assert_allclose(np.linalg.norm(np.diff(paths, axis=0), axis=2), 0.04, rtol=0.02)  # 20 cm/s × 0.2 s
    assert 0 <= result["exposed_steps"] <= 3 * result["steps"]
    assert result["walls"] is False
    assert result["success"] == (result["arrived"] and result["collisions"] == 0)


def test_cli_failures_writes_a_table_for_the_given_seeds(paper001, tmp_path):
    paper001.main(["failures", "--out", str(tmp_path), "--seeds", "1", "--first-seed", "100"])
    text = (tmp_path / "failures.md").read_text()
    assert "seeds 100–100" in text
    assert json.loads((tmp_path / "failures.json").read_text())["seeds"] == [100, 100]


def test_obstacle_table_has_both_success_columns(paper001, tmp_path, monkeypatch):
    monkeypatch.setattr(paper001, "WORKSPACES", {"open-straight": paper001.WORKSPACES["open-straight"]})
    rows = paper001.experiment_obstacles(tmp_path, seeds=1)["rows"]
    assert {r["policy"] for r in rows} == {"nash", "nash-first", "goto"}
    for row in rows:
        assert 0.0 <= row["success"] <= row["all_arrived"] <= 1.0


def test_cli_rejects_bad_seed_ranges(paper001, tmp_path):
    with pytest.raises(SystemExit):
        paper001.main(["obstacles", "--out", str(tmp_path), "--seeds", "0"])
    with pytest.raises(SystemExit):
        paper001.main(["obstacles", "--out", str(tmp_path), "--first-seed", "-1"])


def test_delay_long_runs_modelled_only_up_to_dt_and_reports_the_eq26_case(paper001, tmp_path, monkeypatch):
    monkeypatch.setattr(paper001, "LONG_RANDOM", (1.0,))
    monkeypatch.setattr(paper001, "LONG_FIXED", (1.5,))
    paper001.main(["delay-long", "--out", str(tmp_path), "--seeds", "1", "--first-seed", "3"])
    result = json.loads((tmp_path / "delay-long.json").read_text())
    assert result["seeds"] == [3, 3]
    cases = [(r["T0/dt"], r["true delay"], r["T0 modelled"]) for r in result["rows"]]
    assert cases == [(1.0, "½T0(1+δt)", False), (1.0, "½T0(1+δt)", True), (1.5, "T0", False)]
    unmodelled, eq26, fixed = result["rows"]
    assert eq26["arrived"] == 0  # eq. (26) at T0 = Δt: the decision drops out, the robots cannot steer
    assert unmodelled["arrived"] == fixed["arrived"] == 1
    assert "seeds 3–3" in (tmp_path / "delay-long.md").read_text()


def test_delay_long_random_layout_writes_its_own_table(paper001, tmp_path, monkeypatch):
    monkeypatch.setattr(paper001, "LONG_RANDOM", ())
    monkeypatch.setattr(paper001, "LONG_FIXED", (2.0,))
    paper001.main(["delay-long", "--layout", "random", "--out", str(tmp_path), "--seeds", "2"])
    assert not (tmp_path / "delay-long.md").exists()
    result = json.loads((tmp_path / "delay-long-random.json").read_text())
    assert result["layout"] == "random" and len(result["rows"]) == 1
    assert result["rows"][0]["episodes"] == 2
    assert "layout random" in (tmp_path / "delay-long-random.md").read_text()


def test_delay_long_takes_its_delays_from_the_command_line(paper001, tmp_path):
    paper001.main(["delay-long", "--out", str(tmp_path), "--seeds", "1", "--random-delays", "", "--fixed-delays", "0.5,3"])
    rows = json.loads((tmp_path / "delay-long.json").read_text())["rows"]
    assert [(r["T0/dt"], r["T0 modelled"]) for r in rows] == [(0.5, False), (0.5, True), (3.0, False)]
    for bad in ("0.5,x", "9"):
        with pytest.raises(SystemExit):
            paper001.main(["delay-long", "--out", str(tmp_path), "--fixed-delays", bad])
