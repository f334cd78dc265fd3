"""Decision time of the ``nash`` navigation baseline (paper 001) per control step.

One decision = building the loss tensor of eqs. (15)–(26) for all playing robots and
solving the game with the arbiter (eqs. 27–31). Timed on the states of real episodes of
``Navigation-v0`` (2 obstacles), steps where every robot still plays.

Bars (issue 3): 5 robots, K = 5: under 5 ms per step; 5 robots, K = 17: under 0.5 s.

    python benchmarks/bench_nash_decision.py [--steps 40]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import teamgym
from baselines.registry import make_policy


def decision_times(n_robots: int, levels: int, steps: int, seed: int = 0) -> list[float]:
    env = teamgym.make("Navigation-v0", n_robots=n_robots, action_type="heading", heading_levels=levels, dt=0.2)
    policy = make_policy("nash", env)
    observations, infos = env.reset(seed=seed)
    policy.reset(seed)
    times = []
    while env.agents and len(times) < steps:
        live = {a: observations[a] for a in env.agents}
        started = time.perf_counter()
        actions = policy.act(live, infos)
        elapsed = time.perf_counter() - started
        if len(live) == n_robots:
            times.append(elapsed)
        observations, _, _, _, infos = env.step(actions)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=40)
    args = parser.parse_args()
    print(f"{'robots':>6} {'K':>3} {'joint actions':>14} {'median ms':>10} {'p95 ms':>8} {'max ms':>8}  bar")
    for n, k, bar in ((2, 5, None), (3, 5, None), (5, 5, 5.0), (3, 17, None), (5, 9, None), (5, 17, 500.0)):
        steps = args.steps if k < 17 else max(5, args.steps // 4)
        ms = 1000 * np.asarray(decision_times(n, k, steps))
        verdict = "" if bar is None else f"< {bar:g} ms: {'PASS' if np.percentile(ms, 95) < bar else 'FAIL'} (p95)"
        print(f"{n:>6} {k:>3} {k**n:>14,} {np.median(ms):10.2f} {np.percentile(ms, 95):8.2f} {ms.max():8.2f}  {verdict}")


if __name__ == "__main__":
    main()
