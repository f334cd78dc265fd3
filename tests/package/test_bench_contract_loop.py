"""The API floor of benchmarks/bench_navigation.py (``ContractLoop``): it checks like an env and answers in five dicts."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_navigation.py"
_spec = importlib.util.spec_from_file_location("bench_navigation", _BENCH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def joint(loop, value=0.5):
    return {a: np.full(2, value, np.float32) for a in loop.agents}


def test_contract_step_answers_five_dicts_keyed_by_agent():
    loop = bench.ContractLoop(3)
    out = loop.parallel_step(joint(loop))
    assert len(out) == 5 and all(set(d) == set(loop.agents) for d in out)
    assert out[0]["robot_0"].shape == (14,)  # pose and velocities (6) and 8 rays
    assert all(info == {"success": False} for info in out[4].values())


@pytest.mark.parametrize("bad", [np.nan, 1.5, -2.0])
def test_contract_step_refuses_bad_actions_before_stepping(bad):
    loop = bench.ContractLoop(3)
    loop.parallel_step(joint(loop))
    before = loop.observation.copy()
    actions = joint(loop)
    actions["robot_1"] = np.array([0.0, bad], np.float32)
    with pytest.raises(ValueError, match="outside"):
        loop.parallel_step(actions)
    with pytest.raises(ValueError, match="expected"):
        loop.parallel_step({**joint(loop), "robot_9": np.zeros(2, np.float32)})
    assert np.array_equal(loop.observation, before)
