"""experiments/paper004_box_pushing.py at a tiny size: every policy, both success definitions, dynamic changes."""

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

from baselines.stats import mean_text, rate_text

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "paper004_box_pushing.py"


@pytest.fixture(scope="module")
def paper004():
    spec = importlib.util.spec_from_file_location("paper004_box_pushing", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_rate_and_mean_texts_carry_their_intervals():
    assert rate_text(82, 100) == "82 % [73, 88]"
    assert rate_text(0, 0) == "–"
    assert mean_text([1.0, 3.0, None, float("nan")]) == "2 ± 2 (n=2)"  # 1.96 · √2 / √2
    assert mean_text([]) == "–" and mean_text([5.0]) == "5 (n=1)"


def test_one_robot_delivers_a_light_box_and_the_first_delivery_is_timed(paper004):
    env = ("BoxPushing-v1", {"max_cycles": 300})
    result = paper004.run_static(("S1", "cooperative-push", 107, env))
    assert result["success"] and result["boxes"] == 1
    assert result["first_box_s"] == pytest.approx(result["time_to_goal"])  # one box: both definitions agree


def test_static_table_has_both_success_definitions_for_every_policy(paper004, tmp_path):
    env = ("BoxPushing-v1", {"max_cycles": 60})
    rows = paper004.experiment_static(tmp_path, None, 1, 1, env, ("cooperative-push", "random"), first_seed=7, tag="_t")
    assert [(r["situation"], r["policy"]) for r in rows] == [
        (s, p) for s in paper004.SITUATIONS for p in ("cooperative-push", "random")
    ]
    assert all(r["every box"] == "0 % [0, 79]" and r["a box touches the goal"] == "0 % [0, 79]" for r in rows)
    saved = json.loads((tmp_path / "static_t.json").read_text())
    assert saved["first_seed"] == 7 and {e["seed"] for e in saved["episodes"]} == {7}
    assert (tmp_path / "s3_random_t_failure.png").exists()


@pytest.mark.parametrize("scenario", ["add_heavy", "remove_robot"])
def test_dynamic_changes_happen_at_the_fixed_time_for_any_policy(paper004, scenario, monkeypatch):
    monkeypatch.setattr(paper004, "DYNAMIC_EVENT_S", 2.0)
    env = ("BoxPushing-v1", {"max_cycles": 30})
    result = paper004.run_dynamic_policy((scenario, "cooperative-push", 3, env))
    assert not result["success"] and result["policy"] == "cooperative-push"


def test_cli_rejects_unknown_policies_and_bad_overrides_in_one_line():
    for args in (["--policies", "nope"], ["--set", "noise=-1"], ["--seeds", "0"], ["--situations", "S3,S5"]):
        run = subprocess.run([sys.executable, str(SCRIPT), "static", *args], capture_output=True, text=True, cwd=ROOT)
        assert run.returncode == 2 and "Traceback" not in run.stderr
        assert run.stderr.strip().splitlines()[-1].startswith("paper004_box_pushing.py: error:")


def test_report_puts_runs_side_by_side(paper004, tmp_path):
    env_on, env_off = ("BoxPushing-v1", {"max_cycles": 40}), ("BoxPushing-v1", {"max_cycles": 40, "noise": 0.0})
    paper004.experiment_static(tmp_path, None, 1, 1, env_on, ("random",), first_seed=5, tag="_on")
    paper004.experiment_static(tmp_path, None, 1, 1, env_off, ("random",), first_seed=5, tag="_off")
    text = paper004.report(tmp_path, ["_on", "_off", "_missing"])
    header = text.splitlines()[2]
    assert "every box (v1, noise on, {'max_cycles': 40})" in header
    assert "every box (v1, noise off, {'max_cycles': 40})" in header
    assert text.count("| S3 | random |") == 1 and "dynamic_policies" not in text


def test_static_runs_both_readings_of_sbs_on_the_same_seeds(paper004, tmp_path):
    env = ("BoxPushing-v0", {"max_cycles": 20})
    policies = ("sbs", "sbs-literal")
    rows = paper004.experiment_static(tmp_path, None, 1, 1, env, policies, 31000, "_r", situations=("S2", "S3"))
    assert [(r["situation"], r["policy"]) for r in rows] == [(s, p) for s in ("S2", "S3") for p in policies]
    saved = json.loads((tmp_path / "static_r.json").read_text())
    assert {(e["policy"], e["seed"]) for e in saved["episodes"]} == {("sbs", 31000), ("sbs-literal", 31000)}


def test_pool_merges_runs_split_by_situation_and_seeds(paper004, tmp_path):
    env = ("BoxPushing-v0", {"max_cycles": 20})
    paper004.experiment_static(tmp_path, None, 1, 1, env, ("random",), 5, "_a_S3", situations=("S3",))
    paper004.experiment_static(tmp_path, None, 2, 1, env, ("random",), 6, "_a_S1_6", situations=("S1",))
    text = paper004.pool(tmp_path, ["_a"])
    assert "| S1 | random | 2 | 6–7 | 0 % [0, 66] |" in text and "| S3 | random | 1 | 5–5 |" in text
    paper004.experiment_static(tmp_path, None, 1, 1, env, ("random",), 7, "_a_S1_7", situations=("S1",))
    with pytest.raises(ValueError, match="run twice"):
        paper004.pool(tmp_path, ["_a"])
    with pytest.raises(ValueError, match="no static"):
        paper004.pool(tmp_path, ["_b"])
