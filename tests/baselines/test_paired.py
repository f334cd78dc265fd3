"""baselines.paired: two evaluations compared seed by seed."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from baselines.paired import compare_paired, main, read_metric


def write(tmp_path, name, rows, columns=("episode", "seed", "success", "TT3")):
    folder = tmp_path / name
    folder.mkdir()
    lines = [",".join(columns)] + [",".join(str(v) for v in row) for row in rows]
    (folder / "episodes.csv").write_text("\n".join(lines) + "\n")
    return folder


def test_pairs_by_seed_and_drops_episodes_without_the_metric(tmp_path):
    a = write(tmp_path, "a", [(0, 10, 1, 20.0), (1, 11, 1, 30.0), (2, 12, 0, ""), (3, 13, 1, 25.0)])
    b = write(tmp_path, "b", [(0, 11, 1, 27.0), (1, 10, 1, 18.0), (2, 12, 1, 19.0), (3, 14, 1, 1.0)])
    record = compare_paired(read_metric(a, "TT3"), read_metric(b / "episodes.csv", "TT3"))
    assert (record["common_seeds"], record["pairs"], record["missing_a"], record["missing_b"]) == (3, 2, 1, 0)
    assert record["mean_a"] == pytest.approx(25.0) and record["mean_b"] == pytest.approx(22.5)
    assert record["mean_difference"] == pytest.approx(-2.5)  # seed 10: 18 - 20, seed 11: 27 - 30
    assert (record["b_lower"], record["b_higher"], record["ties"]) == (2, 0, 0)
    assert record["sign_test_p"] == pytest.approx(0.5)  # two of two lower: 2 * (1/4)
    low, high = record["ci95_normal"]
    assert low < -2.5 < high and high - low == pytest.approx(2 * 1.96 * math.sqrt(0.5) / math.sqrt(2))


def test_a_clear_difference_has_an_interval_that_excludes_zero(tmp_path):
    rows_a = [(i, 100 + i, 1, 20.0 + (i % 5)) for i in range(40)]
    rows_b = [(i, 100 + i, 1, 18.0 + (i % 5) + 0.1 * (i % 3)) for i in range(40)]
    record = compare_paired(read_metric(write(tmp_path, "a", rows_a), "TT3"), read_metric(write(tmp_path, "b", rows_b), "TT3"))
    assert record["ci95_normal"][1] < 0 and record["ci95_bootstrap"][1] < 0 and record["b_lower"] == 40
    assert record["sign_test_p"] == pytest.approx(2 * 0.5**40)


def test_cli_prints_and_writes_json(tmp_path, capsys):
    a = write(tmp_path, "a", [(0, 5, 1, 10.0), (1, 6, 1, 12.0), (2, 7, 1, 11.0)])
    b = write(tmp_path, "b", [(0, 5, 1, 9.0), (1, 6, 1, 12.5), (2, 7, 1, 10.0)])
    out = tmp_path / "paired.json"
    assert main([str(a), str(b), "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "3 pairs of 3 common seeds" in printed and "lower in 2, higher in 1" in printed
    record = json.loads(out.read_text())
    assert record["metric"] == "TT3" and record["mean_difference"] == pytest.approx(-0.5)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["missing", "b"], "no episodes.csv at 'missing'"),
        (["a", "b", "--metric", "XX"], "has no 'XX' column; its metrics: success, TT3"),
        (["a", "c"], "share no seed"),
        (["a", "bad"], "TT3 'soon' of seed '5' is not a number"),
        (["a", "b", "--json", "a"], "--json"),
    ],
)
def test_bad_input_is_one_line_exit_2_before_any_output(tmp_path, monkeypatch, capsys, args, needle):
    write(tmp_path, "a", [(0, 5, 1, 10.0)])
    write(tmp_path, "b", [(0, 5, 1, 9.0)])
    write(tmp_path, "c", [(0, 6, 1, 9.0)])
    write(tmp_path, "bad", [(0, 5, 1, "soon")])
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1 and needle in captured.err


@settings(max_examples=60, deadline=None)
@given(
    st.dictionaries(
        st.integers(0, 50),
        st.tuples(st.one_of(st.none(), st.floats(0, 200)), st.one_of(st.none(), st.floats(0, 200))),
        min_size=1,
        max_size=30,
    )
)
def test_the_record_is_consistent_with_its_pairs(table):
    a, b = {s: v[0] for s, v in table.items()}, {s: v[1] for s, v in table.items()}
    record = compare_paired(a, b)
    pairs = [(x, y) for x, y in table.values() if x is not None and y is not None]
    assert record["pairs"] == len(pairs) and record["common_seeds"] == len(table)
    assert record["missing_a"] + record["pairs"] <= len(table) and record["missing_b"] + record["pairs"] <= len(table)
    if pairs:
        assert record["mean_difference"] == pytest.approx(sum(y - x for x, y in pairs) / len(pairs), abs=1e-9)
        assert record["b_lower"] + record["b_higher"] + record["ties"] == len(pairs)
        low, high = record["ci95_bootstrap"]
        assert low - 1e-9 <= record["mean_difference"] <= high + 1e-9
        assert 0.0 <= record["sign_test_p"] <= 1.0
