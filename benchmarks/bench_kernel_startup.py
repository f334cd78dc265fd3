"""Time to a batch's first step in a fresh process, with the compiled kernel and without (``TEAMGYM_KERNEL``).

Each case runs in its own interpreter: import teamgym, make a batch of Navigation-v0 (16 copies),
reset, step once; wall clock from the interpreter's start of the script to the end of that
step. The kernel's first process compiles :mod:`teamgym.sim.compiled_loops` (numba caches them on
disk); later processes load them.

    python benchmarks/bench_kernel_startup.py [--runs 3]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

CHILD = """
import time
start = time.perf_counter()
import numpy as np
import teamgym
batch = teamgym.make_batch("Navigation-v0", 16)
batch.reset(seed=0)
batch.step(np.zeros((16, batch.n_robots, 2), dtype=np.float32))
from teamgym.sim import kernel
print(time.perf_counter() - start, kernel.enabled())
"""


def first_step(kernel_on: bool) -> tuple[float, bool]:
    """Seconds to the first batch step in a new interpreter, and whether the kernel was on."""
    env = {**os.environ, "TEAMGYM_KERNEL": "1" if kernel_on else "0"}
    done = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
    seconds, enabled = done.stdout.split()
    return float(seconds), enabled == "True"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    if args.runs < 1:
        parser.error("--runs >= 1")
    for label, on in (("kernel on", True), ("kernel off", False)):
        times = [first_step(on) for _ in range(args.runs)]
        shown = ", ".join(f"{seconds:.2f}" for seconds, _ in times)
        print(f"{label:11s} (enabled={times[0][1]}): seconds to the first step of a 16-copy batch: {shown}")


if __name__ == "__main__":
    main()
