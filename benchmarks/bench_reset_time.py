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
import statistics
import time
from pathlib import Path

from ab_workers import in_turn, serve, start_workers

ENV_IDS = ("Navigation-v0", "Exploration-v0", "Rendezvous-v0", "Foraging-v0", "BoxPushing-v0", "BoxPushing-v1")
ROOT = Path(__file__).resolve().parents[1]
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


_ENVS: dict = {}


def resets(request: dict) -> list[float]:
    """Worker job: reset ``env`` (made once, then ``warmup`` untimed resets) with each of ``seeds``; times in s."""
    import teamgym

    env_id, tick = request["env"], CLOCKS[request["clock"]]
    if env_id not in _ENVS:
        _ENVS[env_id] = teamgym.make(env_id)
        for seed in range(request["warmup"]):
            _ENVS[env_id].reset(seed=10**6 + seed)
    env, times = _ENVS[env_id], []
    for seed in request["seeds"]:
        began = tick()
        env.reset(seed=seed)
        times.append(tick() - began)
    return times


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
        serve(resets)
        return
    unknown = sorted(set(args.env) - set(ENV_IDS))
    if unknown:
        parser.error(f"unknown env id(s) {unknown}; choose from {list(ENV_IDS)}")
    if args.rounds < 1 or args.block < 1 or args.warmup < 0:
        parser.error(f"need --rounds >= 1, --block >= 1, --warmup >= 0, got {args.rounds}, {args.block}, {args.warmup}")
    try:
        workers = start_workers(__file__, ROOT, args.baseline, [])
    except ValueError as error:
        parser.error(str(error))
    times = {(w, e): [] for w in range(len(workers)) for e in args.env}
    ratios: dict[str, list[float]] = {e: [] for e in args.env}
    try:
        for r in range(args.rounds):
            seeds = list(range(r * args.block, (r + 1) * args.block))
            for env_id in args.env:
                request = {"env": env_id, "seeds": seeds, "warmup": args.warmup, "clock": args.clock}
                block = in_turn(workers, r, request)
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
