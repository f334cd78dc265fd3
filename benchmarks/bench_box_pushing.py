"""Env-steps/s of BoxPushing-v0 (4 robots, 1 heavy box) beside Navigation-v0 (5 robots), in one run.

Both are timed in the same process, interleaved over several rounds; the best round of each
is reported. Navigation-v0 is timed by ``benchmarks/bench_navigation.py``'s own function
(random actions, 2 moving obstacles, resets included). BoxPushing-v0 gets random actions of
its action type (``primitives``: the paper's discrete set, with multi-step primitives;
``wheels``: continuous wheel speeds), drawn before timing, resets included. Optionally the
``sbs`` policy's own decision time is measured too (env plus policy, ``--policy``).

Target (issue 4): BoxPushing-v0 env-steps/s at least 60 % of Navigation-v0 with 5 robots.

    python benchmarks/bench_box_pushing.py [--steps 3000] [--rounds 3] [--policy]
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

import teamgym

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_navigation import time_teamgym as time_navigation  # noqa: E402


def time_box_pushing(action_type: str, steps: int, seed: int = 0) -> float:
    env = teamgym.make("BoxPushing-v0", situation="S3", action_type=action_type)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    space = env.action_space(env.possible_agents[0])
    if action_type == "wheels":
        pool = [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in env.possible_agents} for _ in range(256)]
    else:
        pool = [{a: int(rng.integers(space.n)) for a in env.possible_agents} for _ in range(256)]
    start = time.perf_counter()
    for i in range(steps):
        if not env.agents:
            env.reset()
        actions = pool[i % 256]
        env.step({a: actions[a] for a in env.agents})
    return steps / (time.perf_counter() - start)


def time_sbs(steps: int, seed: int = 0) -> float:
    from baselines.registry import make_policy

    env = teamgym.make("BoxPushing-v0", situation="S3")
    policy = make_policy("sbs", env)
    observations, infos = env.reset(seed=seed)
    policy.reset(seed)
    start = time.perf_counter()
    for _ in range(steps):
        if not env.agents:
            observations, infos = env.reset()
        observations, _, _, _, infos = env.step(policy.act({a: observations[a] for a in env.agents}, infos))
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--policy", action="store_true", help="also time env + sbs policy")
    args = parser.parse_args()
    runs = {
        "Navigation-v0, 5 robots": lambda: time_navigation(5, args.steps),
        "BoxPushing-v0, 4 robots + 1 box, primitives": lambda: time_box_pushing("primitives", args.steps),
        "BoxPushing-v0, 4 robots + 1 box, wheels": lambda: time_box_pushing("wheels", args.steps),
    }
    if args.policy:
        runs["BoxPushing-v0 + sbs policy (4 robots)"] = lambda: time_sbs(args.steps)
    best = dict.fromkeys(runs, 0.0)
    for _ in range(args.rounds):
        for name, run in runs.items():
            best[name] = max(best[name], run())
    nav = best["Navigation-v0, 5 robots"]
    machine = platform.processor() or platform.machine()
    print(f"env-steps/s, best of {args.rounds} rounds x {args.steps} steps ({machine})")
    for name, rate in best.items():
        print(f"  {name:48s} {rate:8.0f}   {rate / nav:6.1%} of Navigation-v0")
    worst = min(best["BoxPushing-v0, 4 robots + 1 box, primitives"], best["BoxPushing-v0, 4 robots + 1 box, wheels"])
    print(f"target: BoxPushing-v0 >= 60% of Navigation-v0 (5 robots): {'met' if worst >= 0.6 * nav else 'NOT met'}")


if __name__ == "__main__":
    main()
