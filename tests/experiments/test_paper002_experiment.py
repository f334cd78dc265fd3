"""experiments/paper002_foraging.py: statistics, one setting, the report and the search time, at a tiny size."""

import importlib.util
import json
import math
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "paper002_foraging.py"


@pytest.fixture(scope="module")
def paper002():
    spec = importlib.util.spec_from_file_location("paper002_foraging", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # worker processes find its functions by name
    spec.loader.exec_module(module)
    return module


def test_wilson_interval_contains_the_rate_and_narrows(paper002):
    low, high = paper002.wilson(45, 50)
    assert low < 0.9 < high < 1.0
    low_big, high_big = paper002.wilson(1800, 2000)
    assert high_big - low_big < high - low
    assert paper002.wilson(0, 10)[0] == pytest.approx(0.0, abs=1e-12)


def test_mean_ci_skips_missing_values(paper002):
    stats = paper002.mean_ci([1.0, 3.0, math.nan])
    assert stats["mean"] == 2.0 and stats["n"] == 2
    assert stats["ci95"] == pytest.approx(1.96 * math.sqrt(2) / math.sqrt(2))


def test_one_setting_and_the_report(paper002, tmp_path):
    config = {**paper002.CONSUME, "comm_throughput": 1.0}
    row = paper002.run_setting(config, paper002.CONSUME_METRICS, games=3, first_seed=0, workers=1, policy="dmaps")
    assert row["games"] == 3 and 0 <= row["successes"] <= 3
    assert row["success"]["low"] <= row["success"]["rate"] <= row["success"]["high"]
    if row["successes"]:
        assert row["TT1"]["mean"] <= row["TT2"]["mean"] <= row["TT3"]["mean"]
        assert row["TT1"]["mean"] >= 10.0  # a target takes consume_time (10 s) to consume
    result = {"sweep": "consume", "policy": "dmaps", "config": paper002.CONSUME, "metrics": list(paper002.CONSUME_METRICS)}
    result["rows"] = {"0.0": row, "1.0": row}
    (tmp_path / "consume.json").write_text(json.dumps(result))
    text = paper002.report(tmp_path)
    assert "| throughput |" in text and "TT3: no difference beyond the 95 % interval (no − full = 0.00" in text


def test_search_time_of_one_robot(paper002):
    times = paper002.search_time(games=1, first_seed=0)
    assert 0 < times["90"]["mean"] <= times["100"]["mean"] < 200


def test_rate_sweeps_of_both_readings_and_their_comparison(paper002, tmp_path):
    for consumed in ("vanish", "persist"):
        args = ["consume", "--radio", "rate", "--consumed", consumed, "--games", "2", "--key-games", "3"]
        assert paper002.main([*args, "--workers", "1", "--out", str(tmp_path), "--quiet"]) == 0
    persist = json.loads((tmp_path / "consume-persist-rate.json").read_text())
    assert persist["axis"] == "packet_rate" and persist["config"]["consumed_targets"] == "persist"
    assert list(persist["rows"]) == [str(r) for r in paper002.RATES]
    assert [row["games"] for row in persist["rows"].values()] == [3, 2, 2, 2, 2, 2, 3]  # --key-games at the ends
    assert "consumed_targets" not in json.loads((tmp_path / "consume-rate.json").read_text())["config"]  # vanish: the default
    text = paper002.report(tmp_path)
    assert "| packets/s |" in text and "**consume-rate: both readings**" in text and "| persist |" in text
    assert (tmp_path / "consume-rate-readings.png").exists()


@pytest.mark.parametrize("bad", [["--radio", "bandwidth"], ["--consumed", "keep"], ["--key-games", "1"]])
def test_bad_radio_options_exit_2_before_any_output(paper002, tmp_path, bad, capsys):
    with pytest.raises(SystemExit) as exit_:
        paper002.main(["consume", *bad, "--out", str(tmp_path / "x")])
    assert exit_.value.code == 2 and not (tmp_path / "x").exists()
    assert len(capsys.readouterr().err.strip().splitlines()[-1]) > 0
