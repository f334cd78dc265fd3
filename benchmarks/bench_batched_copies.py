"""Agent-steps/s of Navigation-v0 copies stepped in one process: batched vs one copy at a time.

Cases (random actions from one fixed table, episodes long enough never to end):

* ``batch K``: :class:`~teamgym.envs.navigation.batch.NavigationBatch` with K copies, one
  ``step`` with a ``(K, N, 2)`` action array (the numpy work is one pass over all copies);
* ``sb3 batch K``: the SB3 adapter :class:`~baselines.rl.sb3_env.TeamVecEnv` over a batch
  (what ``baselines.train`` uses for Navigation), ``step_async``/``step_wait`` with ``K·N`` slots;
* ``sb3 dict K``: the same adapter stepping K PettingZoo envs one after another (``batched=False``).

Rounds interleave the cases; the best round of each is kept (the least disturbed by other
load on a shared machine) and ratios are taken within this one run. ``--clock cpu`` times
process CPU instead of wall time.

    python benchmarks/bench_batched_copies.py [--copies 1 4 16 64] [--robots 3] [--steps 300] [--rounds 5]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable

import numpy as np

from teamgym.envs.navigation.batch import NavigationBatch


def batch_case(copies: int, robots: int, steps: int) -> Callable[[], float]:
    batch = NavigationBatch(copies, n_robots=robots, max_cycles=10**6)
    batch.reset(seed=0)
    space = batch.action_space
    table = np.random.default_rng(0).uniform(space.low, space.high, size=(64, copies, robots, 2)).astype(np.float32)

    def run() -> float:
        for t in range(steps):
            batch.step(table[t % 64])
        return steps * copies * robots

    return run


def sb3_case(copies: int, robots: int, steps: int, batched: bool) -> Callable[[], float]:
    import teamgym
    from baselines.rl.sb3_env import TeamVecEnv

    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", n_robots=robots, max_cycles=10**6), n_envs=copies, batched=batched)
    venv.seed(0)
    venv.reset()
    space = venv.action_space
    table = np.random.default_rng(0).uniform(space.low, space.high, size=(64, venv.num_envs, 2)).astype(np.float32)

    def run() -> float:
        for t in range(steps):
            venv.step_async(table[t % 64])
            venv.step_wait()
        return steps * venv.num_envs

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, nargs="+", default=[1, 4, 16, 64])
    parser.add_argument("--robots", type=int, default=3)
    parser.add_argument("--steps", type=int, default=300, help="steps per timed chunk")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--clock", choices=["wall", "cpu"], default="wall")
    parser.add_argument("--no-sb3", action="store_true", help="time the batch alone")
    parser.add_argument("--json", type=str, default=None)
    args = parser.parse_args()
    clock = time.perf_counter if args.clock == "wall" else time.process_time
    cases: dict[str, Callable[[], float]] = {}
    for k in args.copies:
        cases[f"batch {k}"] = batch_case(k, args.robots, args.steps)
    if not args.no_sb3:
        for k in (min(args.copies), 16):
            cases[f"sb3 batch {k}"] = sb3_case(k, args.robots, args.steps, batched=True)
            cases[f"sb3 dict {k}"] = sb3_case(k, args.robots, args.steps, batched=False)
    best: dict[str, float] = {}
    for _ in range(args.rounds):
        for name, run in cases.items():
            start = clock()
            agent_steps = run()
            best[name] = max(best.get(name, 0.0), agent_steps / (clock() - start))
    base = best[f"batch {min(args.copies)}"]
    print(
        f"Navigation-v0, {args.robots} robots, random velocity actions; best of {args.rounds} x {args.steps} steps, "
        f"{args.clock} clock ({platform.machine()}, {os.cpu_count()} cores)"
    )
    print(f"{'case':<16} {'agent-steps/s':>14} {'vs batch ' + str(min(args.copies)):>12}")
    for name, rate in best.items():
        print(f"{name:<16} {rate:>14.0f} {rate / base:>11.2f}x")
    if not args.no_sb3:
        print(f"sb3 batch 16 / sb3 dict 1: {best['sb3 batch 16'] / best[f'sb3 dict {min(args.copies)}']:.2f}x")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"robots": args.robots, "clock": args.clock, "agent_steps_per_s": best}, handle, indent=2)


if __name__ == "__main__":
    main()
