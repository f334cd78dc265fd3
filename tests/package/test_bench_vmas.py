"""benchmarks/bench_vmas.py refuses bad arguments and a missing VMAS venv in one line, before any work."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_vmas.py"
_spec = importlib.util.spec_from_file_location("bench_vmas", _BENCH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def test_missing_venv_names_the_setup_script(tmp_path):
    missing = tmp_path / "no-venv" / "bin" / "python"
    with pytest.raises(SystemExit) as raised:
        bench.main(["--vmas-python", str(missing)])
    message = str(raised.value.code)
    assert message.startswith("error: no VMAS venv at ") and str(missing) in message
    assert message.endswith("build it with bash scripts/setup_vmas_venv.sh") and "\n" not in message


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--envs", "63"], "--envs (63) must be divisible by --processes (2)"),
        (["--steps", "0"], "--steps"),
        (["--threads", "x"], "--threads"),
    ],
)
def test_bad_arguments_exit_with_usage_error(argv, named, capsys):
    with pytest.raises(SystemExit) as raised:
        bench.parse(argv)
    assert raised.value.code == 2
    assert named in capsys.readouterr().err


def test_defaults_are_the_issue_case():
    args = bench.parse([])
    assert (args.envs, args.robots, args.processes, args.threads) == (64, 3, 2, [1, 2])
