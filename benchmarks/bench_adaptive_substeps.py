"""Adaptive substeps (config ``coarse_substeps``): what they save and what they change.

A control step in which no contact can begin is integrated in ``coarse_substeps`` substeps
instead of ``substeps`` (20); see :class:`teamgym.sim.world.World`. Three measurements on
``Navigation-v0``, each for ``coarse_substeps`` 0 (off, the default) and the values given:

1. **speed**: env steps per second of CPU time with random actions (N robots), interleaved
   chunks, fastest chunk; and the share of control steps that ran coarse;
2. **penetration**: the deepest overlap of a robot with a wall, a robot and an obstacle in
   any physics substep (:class:`teamgym.sim.contacts.PenetrationProbe`), random actions with
   5 robots in a 1 m arena (crowded, many contacts);
3. **metrics**: the scripted policies' table of ``baselines.rl.compare`` (success, clean
   success, time, path, collisions) on the same held-out seeds.

    python benchmarks/bench_adaptive_substeps.py [--coarse 5 10] [--episodes 100] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import teamgym
from teamgym.sim.categories import Category
from teamgym.sim.contacts import PenetrationProbe


def random_pool(env, rng: np.random.Generator, size: int = 256) -> list[dict[str, np.ndarray]]:
    space = env.action_space(env.possible_agents[0])
    return [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in env.possible_agents} for _ in range(size)]


def speed(coarse_values: list[int], n_robots: int, chunk: int, rounds: int) -> dict[int, dict[str, float]]:
    """Fastest chunk (steps per CPU second) and the coarse share, per ``coarse_substeps``."""
    envs = {k: teamgym.make("Navigation-v0", n_robots=n_robots, coarse_substeps=k) for k in coarse_values}
    pools = {}
    for k, env in envs.items():
        env.reset(seed=0)
        pools[k] = random_pool(env, np.random.default_rng(0))
    best = dict.fromkeys(coarse_values, 0.0)
    steps = dict.fromkeys(coarse_values, 0)
    coarse_steps = dict.fromkeys(coarse_values, 0)
    for r in range(rounds + 1):
        for k, env in envs.items():
            begin = time.process_time()
            for i in range(chunk):
                if not env.agents:
                    coarse_steps[k] += env.world.coarse_steps
                    steps[k] += env.world.coarse_steps + env.world.fine_steps
                    env.reset()
                actions = pools[k][(r * chunk + i) % 256]
                env.step({a: actions[a] for a in env.agents})
            if r:  # round 0 warms up
                best[k] = max(best[k], chunk / (time.process_time() - begin))
    for k, env in envs.items():
        coarse_steps[k] += env.world.coarse_steps
        steps[k] += env.world.coarse_steps + env.world.fine_steps
    return {k: {"steps_per_cpu_s": best[k], "coarse_share": coarse_steps[k] / max(1, steps[k])} for k in coarse_values}


def penetration(coarse: int, episodes: int, seed: int = 0) -> dict[str, float]:
    """Deepest overlaps (mm) with random actions, 5 robots in a 1 m arena."""
    env = teamgym.make("Navigation-v0", n_robots=5, arena_size=1.0, min_goal_distance=0.3, coarse_substeps=coarse)
    rng = np.random.default_rng(seed)
    worst = {"robot-wall": 0.0, "robot-robot": 0.0, "robot-obstacle": 0.0, "contacts begun in coarse steps": 0.0}
    kinds = {"robot-wall": Category.WALL, "robot-robot": Category.ROBOT, "robot-obstacle": Category.OBSTACLE}
    pool = None
    for episode in range(episodes):
        env.reset(seed=seed + episode)
        pool = pool or random_pool(env, rng)
        probe = PenetrationProbe(env.world.space)
        for _ in range(env.config.max_cycles):
            if not env.agents:
                break
            actions = pool[int(rng.integers(256))]
            env.step({a: actions[a] for a in env.agents})
        for name, kind in kinds.items():
            worst[name] = max(worst[name], 1000 * probe.deepest(Category.ROBOT, kind))
        worst["contacts begun in coarse steps"] += env.world.coarse_contacts
    return worst


def metrics(coarse: int, episodes: int, seed: int, workers: int) -> list[dict]:
    from baselines.rl.compare import compare

    policies = [("nash (paper 001)", "nash"), ("goto", "goto")]
    return compare("Navigation-v0", None, episodes, seed, workers, task={"coarse_substeps": coarse}, policies=policies)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coarse", type=int, nargs="+", default=[5], help="coarse_substeps values to compare with 0")
    parser.add_argument("--robots", type=int, default=5, help="robots in the speed test")
    parser.add_argument("--chunk", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("--episodes", type=int, default=100, help="held-out episodes per policy for the metrics")
    parser.add_argument("--probe-episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=20_000)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--json", type=str, default=None)
    args = parser.parse_args()
    values = [0, *args.coarse]
    report: dict = {"speed": speed(values, args.robots, args.chunk, args.rounds)}
    print(f"Navigation-v0, {args.robots} robots, random actions: steps per CPU second (fastest of {args.rounds} chunks)")
    base = report["speed"][0]["steps_per_cpu_s"]
    for k in values:
        row = report["speed"][k]
        rate, share = row["steps_per_cpu_s"], 100 * row["coarse_share"]
        print(f"  coarse_substeps={k:>2}: {rate:7.0f}  ({rate / base:.2f}x)  coarse steps {share:.0f} %")
    report["penetration_mm"] = {k: penetration(k, args.probe_episodes) for k in values}
    print(f"Deepest overlap in any substep (mm), 5 robots in a 1 m arena, random actions, {args.probe_episodes} episodes")
    for k in values:
        cells = "  ".join(f"{name} {depth:.2f}" for name, depth in report["penetration_mm"][k].items())
        cells = cells.replace("coarse steps 0.00", "coarse steps 0")
        print(f"  coarse_substeps={k:>2}: {cells}")
    from baselines.rl.compare import markdown

    report["metrics"] = {}
    for k in values:
        rows = metrics(k, args.episodes, args.seed, args.workers)
        report["metrics"][k] = rows
        print(f"\ncoarse_substeps={k}, {args.episodes} held-out seeds from {args.seed}")
        print(markdown(rows))
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(report, handle, indent=2, default=float)


if __name__ == "__main__":
    main()
