"""experiments/paper000_exploration.py table1: paper 000's Table 1 compared cell by cell on the rebuilt office."""

import copy
import importlib.util
import json
import sys
from pathlib import Path

import pytest

from teamgym.maps.model import DATA_DIR

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "paper000_exploration.py"


@pytest.fixture(scope="module")
def paper000():
    spec = importlib.util.spec_from_file_location("paper000_exploration", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def faithful_run(module, **config):
    return module.operator_sequence(
        {**module.TABLE1_SETTING, "map": module.TABLE1_MAP, "stage_end": "all", **config}, **module.TABLE1_POLICY
    )


def test_faithful_setting_has_table_1s_seven_stages_and_20_of_21_cells(paper000):
    run = faithful_run(paper000)
    assert run["success"] and run["stages"] == len(paper000.PAPER_TABLE1) == 7
    assert sum(run["tasks_failed"]) == 0  # robot 1 never tries D3,6
    # robots 2 and 3 row for row; robot 1 heads for D1,2_1 in stage 5 where the paper's waits
    assert paper000.table1_differences(run["short"]) == [{"stage": 5, "robot": 1, "ours": "FD(D1,2_1)", "paper": "W()"}]
    assert [row[1] for row in run["short"]][5] == "TD(D11,12,S12)"  # the paper's TD(D10,11,S12), erratum


def test_per_attempt_reading_sends_robot_1_to_the_closed_door(paper000):
    """Eq. (3) read as L / ((1 − c) o) prices D3,6 (o = 0.2) at 5 L: robot 1 tries it and fails."""
    run = paper000.operator_sequence(
        {**paper000.TABLE1_SETTING, "map": paper000.TABLE1_MAP, "stage_end": "all"}, door_reading="per-attempt"
    )
    assert run["short"][2][0] == "FD(D3,6)" and run["tasks_failed"][0] == 1
    assert {(d["stage"], d["robot"]) for d in paper000.table1_differences(run["short"])} == {(3, 1), (4, 1), (5, 1)}


def test_differences_count_missing_and_extra_stages(paper000):
    rows = [list(row) for row in paper000.PAPER_TABLE1]
    rows[5][1] = "TD(D11,12,S12)"
    assert paper000.table1_differences(rows) == []
    assert paper000.table1_differences(rows[:6]) == [
        {"stage": 7, "robot": i + 1, "ours": "", "paper": paper000.PAPER_TABLE1[6][i]} for i in range(3)
    ]
    assert len(paper000.table1_differences([*rows, ["W()"] * 3])) == 3


@pytest.mark.parametrize(
    "door",
    [
        {"id": "D5,9", "sectors": ["S5", "S9"], "centre": [1310, 400]},
        {"id": "D6,10", "sectors": ["S6", "S10"], "centre": [940, 400]},
        {"id": "D7,11", "sectors": ["S7", "S11"], "centre": [560, 400]},
        {"id": "D2,7", "sectors": ["S2", "S7"], "centre": [560, 600]},
    ],
)
def test_an_unnamed_door_elsewhere_opens_a_shorter_route(paper000, door, tmp_path):
    """Why the unnamed doors sit on the S8-S12 wall: on any other free wall one changes Table 1's plan."""
    office = json.loads((DATA_DIR / "office12-table1.json").read_text())
    variant = copy.deepcopy(office)
    variant["name"] = f"variant {door['id']}"
    variant["doors"].append({**door, "radius": 70, "width": 110, "open_probability": 1.0})
    path = tmp_path / "variant.json"
    path.write_text(json.dumps(variant))
    baseline = paper000.table1_differences(faithful_run(paper000)["short"])
    assert len(paper000.table1_differences(faithful_run(paper000, map=str(path))["short"])) > len(baseline)


def test_cli_prints_table_1_beside_ours_and_with_check_exits_1_on_a_differing_cell(paper000, tmp_path, capsys):
    assert paper000.main(["table1", "--out", str(tmp_path), "--check"]) == 1
    text = capsys.readouterr().out
    assert "| faithful | office12-table1 | return-trip | all | 7 | 7 | 20/21 |" in text
    assert "stage 5, robot 1: ours FD(D1,2_1), paper W()" in text
    assert "Beside it, Table 2 on lab7" in text
    saved = json.loads((tmp_path / "table1.json").read_text())
    assert saved["differences"] == [{"stage": 5, "robot": 1, "ours": "FD(D1,2_1)", "paper": "W()"}]
    assert {row["door_reading"]: row["paper stages"] for row in saved["beside"]} == {"return-trip": 11, "per-attempt": 11}
    assert paper000.main(["table1", "--out", str(tmp_path)]) == 0
