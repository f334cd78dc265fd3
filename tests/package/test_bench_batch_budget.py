"""benchmarks/bench_batch_budget.py counts control steps and substep time without changing the worlds' step."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

import teamgym
from teamgym.sim.world import World

_DIR = Path(__file__).resolve().parents[2] / "benchmarks"
sys.path.insert(0, str(_DIR))
_spec = importlib.util.spec_from_file_location("bench_batch_budget", _DIR / "bench_batch_budget.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def test_control_steps_of_a_lone_run_are_its_env_steps_when_each_step_is_one_control_step():
    calls, spent, (agent_steps, _) = bench.watch_substeps(lambda: bench.lone_run("Navigation-v0", 5))
    assert calls == 5 and agent_steps == 15 and spent > 0.0
    assert World._integrate.__qualname__ == "World._integrate"  # restored


def test_a_macro_step_counts_every_control_step_it_runs():
    calls, _, (agent_steps, _) = bench.watch_substeps(lambda: bench.lone_run("Rendezvous-v0", 2))
    env = teamgym.make("Rendezvous-v0")
    env.reset(seed=0)
    assert calls > 2 and agent_steps == 2 * len(env.possible_agents)


def test_timing_the_substeps_leaves_the_rollout_unchanged():
    batch, run = bench.batch_run("Navigation-v0", 3, 4)
    run()
    plain = [env.world.robot_states.copy() for env in batch.copies]
    assert bench.watch_substeps(run)[1] > 0.0
    watched = [env.world.robot_states.copy() for env in batch.copies]
    assert all(np.array_equal(a, b) for a, b in zip(plain, watched))
    assert World._integrate.__qualname__ == "World._integrate"


def test_worlds_stepped_by_the_kernel_count_one_control_step_each(monkeypatch):
    from teamgym.sim import kernel, world_group

    if not kernel.enabled():
        pytest.skip("numba not installed: every world steps through World._integrate (the tests above)")
    monkeypatch.setattr(world_group, "MIN_ROBOTS_TOGETHER", 0)
    batch, run = bench.batch_run("Navigation-v0", 3, 4)
    calls, spent, _ = bench.watch_substeps(run)
    assert batch._phases._group_plans._together._compiled is not None  # the kernel stepped them
    assert calls == 3 * 4 and spent > 0.0
    assert kernel.WorldsKernel.step.__qualname__ == "WorldsKernel.step"
