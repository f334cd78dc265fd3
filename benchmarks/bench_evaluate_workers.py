"""Wall time of the evaluation CLI with 1 and 2 worker processes, as a user runs it.

Each run is a fresh ``python -m baselines.evaluate --env ENV --policy POLICY --episodes E
--workers W --out DIR`` process (imports, plotting of ``trajectories.png`` and the summary
included), the two worker counts alternated over ``--rounds`` rounds; the median wall time
of each and the ratio of medians are printed, and the summaries are checked to be identical
(results must not depend on the worker count). Meant for an otherwise idle machine.

    python benchmarks/bench_evaluate_workers.py [--policy goto] [--episodes 20] [--rounds 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(args: argparse.Namespace, workers: int, out: Path) -> float:
    command = [sys.executable, "-m", "baselines.evaluate", "--env", args.env, "--policy", args.policy]
    command += ["--episodes", str(args.episodes), "--seed", str(args.seed), "--workers", str(workers), "--out", str(out)]
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="Navigation-v0")
    parser.add_argument("--policy", default="goto")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    times: dict[int, list[float]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as tmp:
        summaries = {}
        for _ in range(args.rounds):
            for workers in (1, 2):
                out = Path(tmp) / f"w{workers}"
                times[workers].append(run(args, workers, out))
                summary = json.loads((out / "summary.json").read_text())
                summaries[workers] = {k: v for k, v in summary.items() if k != "workers"}
        identical = summaries[1] == summaries[2]
    one, two = statistics.median(times[1]), statistics.median(times[2])
    print(f"{args.env} --policy {args.policy}, {args.episodes} episodes, {args.rounds} rounds (median wall s)")
    print(f"  --workers 1: {one:6.2f} s   (runs: {', '.join(f'{t:.2f}' for t in times[1])})")
    print(f"  --workers 2: {two:6.2f} s   (runs: {', '.join(f'{t:.2f}' for t in times[2])})")
    print(f"  workers 2 / workers 1: {two / one:.2f}x the time; summaries identical: {identical}")


if __name__ == "__main__":
    main()
