"""Foraging-v0 + DMAPS (paper 002): one 2,000-game setting with worker processes, and its cost per step.

Part 1 runs the consume setting of section 5.1 (2 robots, 3 targets, ``comm_throughput`` =
``--throughput``) for ``--games`` games with ``--workers`` processes through
:func:`baselines.evaluate.evaluate`, the path the experiment uses, and reports the wall time
(target: under 10 minutes for 2,000 games with 2 workers on a 2-core machine).

Part 2 checks that results do not depend on the worker count: the first ``--check`` games run
with 1 worker and with ``--workers`` workers must give identical episode results (seed,
length, success, returns, metrics).

Part 3 splits the time of one process: env steps vs DMAPS decisions, per control step, over
``--profile-games`` games (ratios measured in the same run).

    python benchmarks/bench_foraging.py [--games 2000] [--workers 2] [--check 100] [--throughput 1.0]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import teamgym
from baselines.episode import run_episode
from baselines.evaluate import evaluate
from baselines.registry import make_policy

CONSUME = {"task": "consume", "n_robots": 2, "n_targets": 3}


class _TimedPolicy:
    """Wraps a policy and sums the time of its ``act`` calls."""

    def __init__(self, policy) -> None:
        self.policy = policy
        self.seconds = 0.0
        self.calls = 0

    def reset(self, seed=None) -> None:
        self.policy.reset(seed)

    def act(self, observations, infos=None):
        start = time.perf_counter()
        actions = self.policy.act(observations, infos)
        self.seconds += time.perf_counter() - start
        self.calls += 1
        return actions


def split(games: int, throughput: float) -> dict[str, float]:
    """Per-step seconds of env and policy in one process."""
    env = teamgym.make("Foraging-v0", comm_throughput=throughput, **CONSUME)
    policy = _TimedPolicy(make_policy("dmaps", env))
    start = time.perf_counter()
    steps = sum(run_episode(env, policy, seed=10_000 + s, record_trajectories=False).length for s in range(games))
    total = time.perf_counter() - start
    return {"steps": steps, "total_ms_per_step": 1e3 * total / steps, "policy_ms_per_step": 1e3 * policy.seconds / steps}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--games", type=int, default=2000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--check", type=int, default=100, help="games compared between 1 and --workers workers")
    parser.add_argument("--throughput", type=float, default=1.0)
    parser.add_argument("--profile-games", type=int, default=20)
    args = parser.parse_args()
    config = {**CONSUME, "comm_throughput": args.throughput}
    print(f"# Foraging-v0 dmaps benchmark on {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs")

    start = time.perf_counter()
    results = evaluate("Foraging-v0", "dmaps", episodes=args.games, seed=0, config=config, workers=args.workers)
    wall = time.perf_counter() - start
    wins = sum(r.success for r in results)
    steps = sum(r.length for r in results)
    print(
        f"part 1: {args.games} games, {args.workers} workers: {wall:.1f} s wall ({wall / 60:.2f} min), "
        f"{1e3 * wall / args.games:.1f} ms per game, {steps / wall:.0f} env steps/s, success {100 * wins / args.games:.1f}%"
    )

    sequential = evaluate("Foraging-v0", "dmaps", episodes=args.check, seed=0, config=config, workers=1)
    same = sequential == results[: args.check]
    print(f"part 2: first {args.check} games with 1 and {args.workers} workers identical: {same}")

    cost = split(args.profile_games, args.throughput)
    share = cost["policy_ms_per_step"] / cost["total_ms_per_step"]
    env_ms = cost["total_ms_per_step"] - cost["policy_ms_per_step"]
    print(
        f"part 3: {cost['total_ms_per_step']:.3f} ms per control step (2 robots), of which DMAPS "
        f"{cost['policy_ms_per_step']:.3f} ms ({100 * share:.0f}%), env {env_ms:.3f} ms"
    )


if __name__ == "__main__":
    main()
