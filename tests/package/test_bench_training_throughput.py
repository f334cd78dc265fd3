"""The command line of benchmarks/bench_training_throughput.py: bad flags exit 2 naming the flag; the cases of --baseline."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

_BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_training_throughput.py"
_spec = importlib.util.spec_from_file_location("bench_training_throughput", _BENCH)
bench = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = bench  # dataclasses look their module up
_spec.loader.exec_module(bench)


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["--env", "Nowhere-v0"], "--env"),
        (["--workers", "5", "--n-envs", "4"], "--workers"),
        (["--timesteps", "0"], "--timesteps"),
        (["--rounds", "0"], "--rounds"),
        (["--json", "/no/such/dir/out.json"], "--json"),
    ],
)
def test_bad_arguments_exit_2_naming_the_flag(argv, flag, capsys):
    with pytest.raises(SystemExit) as exit_info:
        bench.parse_args(argv)
    assert exit_info.value.code == 2
    assert flag in capsys.readouterr().err.splitlines()[-1]


def test_a_baseline_without_the_packages_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        bench.parse_args(["--baseline", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "--baseline" in capsys.readouterr().err


def test_baseline_cases_are_before_after_and_per_copy_with_the_masked_algorithm():
    root = str(bench.ROOT)
    args = bench.parse_args(["--env", "Rendezvous-v0", "--env", "Navigation-v0", "--baseline", root])
    cases = bench.build_cases(args)
    assert [(c.env, c.variant, c.batched) for c in cases] == [
        (env, variant, batched)
        for env in ("Rendezvous-v0", "Navigation-v0")
        for variant, batched in (("before", None), ("after", None), ("per copy", False))
    ]
    assert {c.env: c.algo for c in cases} == {"Rendezvous-v0": "maskable_ppo", "Navigation-v0": "ppo"}
    assert all(c.config == {} for c in cases)
