"""Median time of ``reset`` of every env id (default config), A/B against another checkout in one run.

One worker process per checkout imports that checkout's teamgym (``PYTHONPATH``) and makes
each env once. The parent then runs ``--rounds`` rounds; in each round, for every env id, it
asks the workers in turn (alternating which goes first) for ``--block`` resets with the same
seeds, after ``--warmup`` resets of that env the first time. Each reset is timed alone
(``--clock``: ``cpu`` = ``time.process_time``, the default, or ``wall``). Printed per env: the
median reset time over all rounds of each checkout, the ratio of the medians (this checkout
over the baseline), and the range of the per-round ratios.

    python benchmarks/bench_reset_time.py [--baseline DIR] [--env Rendezvous-v0 ...] [--rounds 10] [--block 40]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ENV_IDS = ("Navigation-v0", "Exploration-v0", "Rendezvous-v0", "Foraging-v0", "BoxPushing-v0", "BoxPushing-v1")
ROOT = Path(__file__).resolve().parents[1]
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def serve(clock: str) -> None:
    """Worker loop: each stdin line ``{"env", "seeds", "warmup"}`` is answered with the reset times (s), one JSON line."""
    import teamgym

    tick, envs = CLOCKS[clock], {}
    print(json.dumps({"teamgym": teamgym.__file__}), flush=True)
    for line in sys.stdin:
        request = json.loads(line)
        env_id = request["env"]
        if env_id not in envs:
            envs[env_id] = teamgym.make(env_id)
            for seed in range(request["warmup"]):
                envs[env_id].reset(seed=10**6 + seed)
        env, times = envs[env_id], []
        for seed in request["seeds"]:
            began = tick()
            env.reset(seed=seed)
            times.append(tick() - began)
        print(json.dumps(times), flush=True)


class Worker:
    """A worker process importing the teamgym package of ``checkout``."""

    def __init__(self, checkout: Path, clock: str) -> None:
        path = os.pathsep.join([str(checkout), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        environment = {**os.environ, "PYTHONPATH": path}
        environment.setdefault("SDL_VIDEODRIVER", "dummy")
        command = [sys.executable, __file__, "--worker", "--clock", clock]
        self.process = subprocess.Popen(command, env=environment, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.package = Path(json.loads(self._read())["teamgym"]).parents[1]

    def _read(self) -> str:
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"worker for {self.package if hasattr(self, 'package') else 'a checkout'} exited")
        return line

    def resets(self, env_id: str, seeds: list[int], warmup: int) -> list[float]:
        self.process.stdin.write(json.dumps({"env": env_id, "seeds": seeds, "warmup": warmup}) + "\n")
        self.process.stdin.flush()
        return json.loads(self._read())

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=list(ENV_IDS), help="env ids (default: all six)")
    parser.add_argument("--baseline", type=Path, help="another checkout (e.g. of main) to time in the same run")
    parser.add_argument("--rounds", type=int, default=10, help="rounds of interleaved blocks (default 10)")
    parser.add_argument("--block", type=int, default=40, help="resets per env, checkout and round (default 40)")
    parser.add_argument("--warmup", type=int, default=20, help="untimed resets of each env first (default 20)")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu", help="CPU (default) or wall time")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        serve(args.clock)
        return
    unknown = sorted(set(args.env) - set(ENV_IDS))
    if unknown:
        parser.error(f"unknown env id(s) {unknown}; choose from {list(ENV_IDS)}")
    if args.rounds < 1 or args.block < 1 or args.warmup < 0:
        parser.error(f"need --rounds >= 1, --block >= 1, --warmup >= 0, got {args.rounds}, {args.block}, {args.warmup}")
    if args.baseline is not None and not (args.baseline / "teamgym" / "__init__.py").is_file():
        parser.error(f"--baseline {args.baseline} holds no teamgym package")
    workers = [Worker(ROOT, args.clock)]
    if args.baseline is not None:
        workers.append(Worker(args.baseline.resolve(), args.clock))
    times = {(w, e): [] for w in range(len(workers)) for e in args.env}
    ratios: dict[str, list[float]] = {e: [] for e in args.env}
    try:
        for r in range(args.rounds):
            seeds = list(range(r * args.block, (r + 1) * args.block))
            for env_id in args.env:
                order = range(len(workers)) if r % 2 == 0 else reversed(range(len(workers)))
                block = {w: workers[w].resets(env_id, seeds, args.warmup) for w in order}
                for w, values in block.items():
                    times[w, env_id] += values
                if len(workers) == 2:
                    ratios[env_id].append(statistics.median(block[0]) / statistics.median(block[1]))
    finally:
        for worker in workers:
            worker.close()
    print(f"median reset time, default config, {args.rounds} rounds x {args.block} resets ({args.clock} clock)")
    print("  " + "   ".join(f"[{w}] {worker.package}" for w, worker in enumerate(workers)))
    for env_id in args.env:
        medians = [statistics.median(times[w, env_id]) * 1e3 for w in range(len(workers))]
        line = f"  {env_id:<15}" + "".join(f" {m:9.3f} ms" for m in medians)
        if len(workers) == 2:
            low, high = min(ratios[env_id]), max(ratios[env_id])
            line += f"   [0]/[1] {medians[0] / medians[1]:.2f}x (rounds {low:.2f}-{high:.2f})"
        print(line)


if __name__ == "__main__":
    main()
