"""Decision time of the ``nash`` navigation baseline (paper 001) per control step.

One decision = building the loss tensor of eqs. (15)–(26) for all playing robots and
solving the game with the arbiter (eqs. 27–31). Timed on the states of real episodes of
``Navigation-v0`` (2 obstacles, Δt = 0.2 s; seeds 0, 1, … until ``--steps`` decisions are
collected), steps where every robot still plays.

Bars: 5 robots, K = 5: median at most 1 ms (issue 15; p95 under 5 ms, issue 3);
5 robots, K = 17: p95 under 0.5 s (issue 3). Timings depend on the machine and its load:
compare runs made under the same conditions.

    python benchmarks/bench_nash_decision.py [--steps 40] [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import teamgym
from baselines.registry import make_policy

#: (robots, K, p95 bar in ms, median bar in ms); None: no bar.
CASES: tuple[tuple[int, int, float | None, float | None], ...] = (
    (2, 5, None, None),
    (3, 5, None, None),
    (5, 5, 5.0, 1.0),
    (3, 17, None, None),
    (5, 9, None, None),
    (5, 17, 500.0, None),
)


def decision_times(n_robots: int, levels: int, steps: int, seed: int = 0) -> list[float]:
    """Seconds per decision on the first ``steps`` full-team steps of episodes ``seed``, ``seed + 1``, …"""
    env = teamgym.make("Navigation-v0", n_robots=n_robots, action_type="heading", heading_levels=levels, dt=0.2)
    policy = make_policy("nash", env)
    times: list[float] = []
    while len(times) < steps:
        observations, infos = env.reset(seed=seed)
        policy.reset(seed)
        while env.agents and len(times) < steps:
            live = {a: observations[a] for a in env.agents}
            started = time.perf_counter()
            actions = policy.act(live, infos)
            elapsed = time.perf_counter() - started
            if len(live) == n_robots:
                times.append(elapsed)
            observations, _, _, _, infos = env.step(actions)
        seed += 1
    return times


def verdict(ms: np.ndarray, p95_bar: float | None, median_bar: float | None) -> str:
    """PASS/FAIL against the bars of a case ('' without bars)."""
    out = []
    if median_bar is not None:
        out.append(f"median <= {median_bar:g} ms: {'PASS' if np.median(ms) <= median_bar else 'FAIL'}")
    if p95_bar is not None:
        out.append(f"p95 < {p95_bar:g} ms: {'PASS' if np.percentile(ms, 95) < p95_bar else 'FAIL'}")
    return "; ".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=40, help="decisions timed per case (K = 17: a quarter)")
    parser.add_argument("--quick", action="store_true", help="only 5 robots, K = 5")
    args = parser.parse_args()
    print(f"{'robots':>6} {'K':>3} {'joint actions':>14} {'median ms':>10} {'p95 ms':>8} {'max ms':>8}  bars")
    for n, k, p95_bar, median_bar in CASES:
        if args.quick and (n, k) != (5, 5):
            continue
        steps = args.steps if k < 17 else max(5, args.steps // 4)
        ms = 1000 * np.asarray(decision_times(n, k, steps))
        row = f"{n:>6} {k:>3} {k**n:>14,} {np.median(ms):10.3f} {np.percentile(ms, 95):8.3f} {ms.max():8.3f}"
        print(f"{row}  {verdict(ms, p95_bar, median_bar)}", flush=True)


if __name__ == "__main__":
    main()
