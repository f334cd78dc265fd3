"""Memory growth and time of ``reset`` over many episodes, each env in its own fresh process.

For every env id: ``--warmup`` resets, then ``--resets`` more with new seeds; prints the
growth of the process's resident set (``/proc/self/statm``, read after a garbage collection
and glibc's ``malloc_trim``; ``--no-trim`` skips the trim) after the warm-up, in MB, at a
quarter, half, three quarters and all of the resets (a leak grows linearly), the growth per
reset, and the median time of one ``reset`` call. Exits with status 1 if any env grows by
``--limit-mb`` (5 MB) or more. ``--baseline DIR`` measures the teamgym package in ``DIR``
too (e.g. a checkout of main), in its own processes, right after each env's run here, and
prints the ratio of the median reset times (same machine state, one run); ``--package DIR``
measures ``DIR``'s teamgym instead of this checkout's.

    python benchmarks/bench_reset_memory.py [--resets 2000] [--env Rendezvous-v0 ...] [--baseline /work/main]
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import ctypes.util
import gc
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


def rss_mb() -> float:
    """Resident set size of this process in MB (``/proc/self/statm``; peak RSS from ``resource`` elsewhere)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except OSError:
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3  # kB on Linux; a peak, not the current size


def release_free_memory() -> None:
    """Collect garbage and, with glibc, hand the allocator's free pages back to the system (``malloc_trim``).

    Without it the resident set also counts free memory the allocator keeps (its heap top moves
    by a few MB from one reading to the next), which is not held by anything.
    """
    gc.collect()
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim(0)


def measure(env_id: str, resets: int, warmup: int, clock: str, trim: bool) -> dict:
    """Run in a worker process: RSS growth (MB) at each quarter of ``resets`` and the median reset time (s)."""
    import teamgym

    settle = release_free_memory if trim else gc.collect
    tick = CLOCKS[clock]
    env = teamgym.make(env_id)
    for seed in range(warmup):
        env.reset(seed=seed)
    settle()
    start = rss_mb()
    marks = {resets * q // 4 for q in (1, 2, 3, 4)}
    times, growth = [], []
    for k in range(1, resets + 1):
        began = tick()
        env.reset(seed=warmup + k)
        times.append(tick() - began)
        if k in marks:
            settle()
            growth.append(rss_mb() - start)
    return {"growth_mb": growth, "reset_s": statistics.median(times), "teamgym": teamgym.__file__}


def run_worker(env_id: str, args: argparse.Namespace, package: Path) -> dict:
    """``measure`` in a fresh interpreter that imports teamgym from ``package``."""
    command = [sys.executable, __file__, "--worker", env_id, "--resets", str(args.resets)]
    command += ["--warmup", str(args.warmup), "--clock", args.clock, *(["--no-trim"] if args.no_trim else [])]
    environment = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(package), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
    }
    environment.setdefault("SDL_VIDEODRIVER", "dummy")
    done = subprocess.run(command, env=environment, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def row(label: str, result: dict, resets: int) -> str:
    growth = result["growth_mb"]
    marks = " ".join(f"{g:6.2f}" for g in growth)
    per_reset = growth[-1] * 1e3 / resets
    return f"  {label:<36} {growth[-1]:8.2f} MB   {per_reset:6.2f} kB/reset   {result['reset_s'] * 1e3:8.2f} ms   ({marks})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resets", type=int, default=2000, help="measured resets per env (default 2000)")
    parser.add_argument("--warmup", type=int, default=200, help="resets before the measurement (default 200)")
    parser.add_argument("--env", nargs="+", default=list(ENV_IDS), help="env ids (default: all six)")
    parser.add_argument("--limit-mb", type=float, default=5.0, help="exit 1 if an env grows by this much or more")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="time resets by wall or CPU time")
    parser.add_argument("--package", type=Path, default=ROOT, help="checkout whose teamgym is measured (default: this one)")
    parser.add_argument("--baseline", type=Path, help="also measure the teamgym package in this checkout")
    parser.add_argument("--no-trim", action="store_true", help="read RSS without malloc_trim first (allocator slack included)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.resets < 4 or args.warmup < 0:
        parser.error(f"need --resets >= 4 and --warmup >= 0, got {args.resets} and {args.warmup}")
    if args.worker:
        print(json.dumps(measure(args.worker, args.resets, args.warmup, args.clock, not args.no_trim)))
        return
    unknown = sorted(set(args.env) - set(ENV_IDS))
    if unknown:
        parser.error(f"unknown env id(s) {unknown}; choose from {list(ENV_IDS)}")
    for option, checkout in (("--package", args.package), ("--baseline", args.baseline)):
        if checkout is not None and not (checkout / "teamgym" / "__init__.py").is_file():
            parser.error(f"{option} {checkout} holds no teamgym package")
    trim = "no trim" if args.no_trim else "RSS after malloc_trim"
    print(f"{args.resets} resets after {args.warmup} warm-up resets, each env in a fresh process ({args.clock} clock, {trim})")
    print(f"  {'':<36} {'RSS growth':>11}   {'per reset':>14}   {'median reset':>11}   (growth MB at 25/50/75/100 %)")
    failed = []
    for env_id in args.env:
        result = run_worker(env_id, args, args.package.resolve())
        print(f"{env_id}")
        print(row(f"teamgym at {Path(result['teamgym']).parents[1]}", result, args.resets))
        if result["growth_mb"][-1] >= args.limit_mb:
            failed.append(env_id)
        if args.baseline is not None:
            base = run_worker(env_id, args, args.baseline.resolve())
            print(row(f"teamgym at {Path(base['teamgym']).parents[1]}", base, args.resets))
            print(f"  median reset time: {result['reset_s'] / base['reset_s']:.2f}x the baseline's")
    if failed:
        print(f"grew by {args.limit_mb} MB or more: {', '.join(failed)}")
        sys.exit(1)
    print(f"every env grew by less than {args.limit_mb} MB")


if __name__ == "__main__":
    main()
