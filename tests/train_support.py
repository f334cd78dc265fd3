"""A check shared by the training tests: a saved model's ``evaluate`` figures equal training's own evaluation."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest

#: the columns of training's evaluation CSV that ``baselines.evaluate``'s summary must repeat
COLUMNS = ("success_rate", "mean_return", "mean_episode_length")


def evaluate_matches_training(out: Path, episodes: int, seed: int, report: Path) -> tuple[dict[str, str], dict[str, Any]]:
    """``evaluate --policy sb3:out`` on training's evaluation seeds gives the last row of ``<out>_eval.csv``.

    Returns that row and the evaluation's ``summary.json`` for further checks.
    """
    from baselines.evaluate import main as evaluate_main

    with out.with_name(f"{out.stem}_eval.csv").open() as handle:
        last = list(csv.DictReader(handle))[-1]
    command = ["--policy", f"sb3:{out}", "--episodes", str(episodes), "--seed", str(seed), "--out", str(report), "--quiet"]
    assert evaluate_main(command) == 0
    summary = json.loads((report / "summary.json").read_text())
    for column in COLUMNS:
        assert float(last[column]) == pytest.approx(summary[column], rel=1e-12, abs=1e-15), column
    return last, summary
