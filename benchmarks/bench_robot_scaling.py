"""Cost per agent-step of Navigation-v0 as the team grows, lone and batched, optionally A/B against another checkout.

Cases (random velocity actions from a fixed table; episodes never time out; a robot that
arrives leaves, and agent-steps count the robots actually stepped):

* ``lone N``: one ``Navigation-v0`` env with N robots (``--robots``, default 3 10 32 64) and
  ``max(2, N // 8)`` obstacles; PettingZoo ``step`` with a dict of actions;
* ``batch K×N``: ``teamgym.make_batch("Navigation-v0", K, n_robots=N)`` (``--batch``, default
  64×3 and 4×64), one ``step`` with a ``(K, N, 2)`` array;
* ``physics K×N``: the same K spaces (another batch, same seed) stepped with Chipmunk's step
  alone, ``substeps`` per control step and nothing else: the floor of a batch step.

Every case runs in one worker process per checkout, in chunks (``--chunk-ms``, fixed step
counts per case chosen so a chunk takes about that long); rounds alternate between the
checkouts (``--baseline DIR`` starts a second worker with ``PYTHONPATH=DIR``, e.g. a
``git worktree`` of main), switching which goes first every round, and the fastest chunk of
each case is kept (CPU clock by default: ``time.process_time`` of the worker). Ratios are
taken within the one run.

    python benchmarks/bench_robot_scaling.py [--baseline /work/wt-base] [--rounds 12] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()


def lone_case(n: int, seed: int = 0) -> Callable[[int], tuple[int, float]]:
    import teamgym

    env = teamgym.make("Navigation-v0", n_robots=n, n_obstacles=max(2, n // 8), max_cycles=10**6)
    env.reset(seed=seed)
    space = env.action_space(env.possible_agents[0])
    table = np.random.default_rng(seed).uniform(space.low, space.high, size=(64, n, 2)).astype(np.float32)
    index = {a: i for i, a in enumerate(env.possible_agents)}
    clock = [0]

    def run(steps: int, timer: Callable[[], float]) -> tuple[int, float]:
        agent_steps, start = 0, timer()
        for _ in range(steps):
            if not env.agents:
                env.reset()
            row = table[clock[0] % 64]
            clock[0] += 1
            agent_steps += len(env.agents)
            env.step({a: row[index[a]] for a in env.agents})
        return agent_steps, timer() - start

    return run


def _make_batch(k: int, n: int, seed: int):
    import teamgym

    maker = getattr(teamgym, "make_batch", None)
    if maker is not None:
        batch = maker("Navigation-v0", k, n_robots=n, max_cycles=10**6)
    else:  # checkouts before make_batch
        from teamgym.envs.navigation.batch import NavigationBatch

        batch = NavigationBatch(k, n_robots=n, max_cycles=10**6)
    batch.reset(seed=seed)
    return batch


def batch_case(k: int, n: int, seed: int = 0) -> Callable[[int], tuple[int, float]]:
    batch = _make_batch(k, n, seed)
    space = batch.action_space
    table = np.random.default_rng(seed).uniform(space.low, space.high, size=(64, k, n, 2)).astype(np.float32)
    clock = [0]

    def run(steps: int, timer: Callable[[], float]) -> tuple[int, float]:
        agent_steps, start = 0, timer()
        for _ in range(steps):
            over = np.flatnonzero(batch.episode_over())
            for copy in over.tolist():
                batch.reset_copy(copy)
            agent_steps += int(batch.active.sum())
            batch.step(table[clock[0] % 64])
            clock[0] += 1
        return agent_steps, timer() - start

    return run


def physics_case(k: int, n: int, seed: int = 0) -> Callable[[int], tuple[int, float]]:
    from pymunk._chipmunk import lib

    batch = _make_batch(k, n, seed)
    worlds = [env.world for env in batch.copies]
    handles = [w.space._space for w in worlds]
    substeps, h = worlds[0].substeps, worlds[0].dt / worlds[0].substeps
    step = lib.cpSpaceStep

    def run(steps: int, timer: Callable[[], float], batch=batch) -> tuple[int, float]:  # the batch keeps the spaces alive
        start = timer()
        for _ in range(steps):
            for handle in handles:
                for _ in range(substeps):
                    step(handle, h)
        return steps * k * n, timer() - start

    return run


def build_cases(robots: list[int], batches: list[tuple[int, int]]) -> dict[str, tuple[Callable, int]]:
    """Case name -> (run, steps per chunk of about 40 ms on a 2020s x86 core)."""
    cases: dict[str, tuple[Callable, int]] = {}
    for n in robots:
        cases[f"lone {n}"] = (lone_case(n), max(4, int(40_000 / (130 + 25 * n))))
    for k, n in batches:
        cases[f"batch {k}x{n}"] = (batch_case(k, n), max(2, int(40_000 / (k * (45 + 25 * n)))))
        cases[f"physics {k}x{n}"] = (physics_case(k, n), max(2, int(40_000 / (k * (30 + 8 * n)))))
    return cases


def worker(args: argparse.Namespace) -> None:
    """Build the cases, then run one chunk of each per line read from stdin; print per-case (agent-steps, seconds)."""
    timer = time.process_time if args.clock == "cpu" else time.perf_counter
    cases = build_cases(args.robots, args.batch)
    for run, steps in cases.values():
        run(max(1, steps // 4), timer)  # warm-up
    print(json.dumps({"ready": list(cases)}), flush=True)
    for line in sys.stdin:
        if line.strip() != "round":
            break
        print(json.dumps({name: run(steps, timer) for name, (run, steps) in cases.items()}), flush=True)


def start_worker(path: str | None, args: argparse.Namespace) -> subprocess.Popen:
    env = dict(os.environ)
    if path is not None:
        env["PYTHONPATH"] = os.pathsep.join([path, *filter(None, [env.get("PYTHONPATH")])])
    command = [sys.executable, str(HERE), "--worker", "--clock", args.clock, "--robots", *map(str, args.robots)]
    command += ["--batch", *[f"{k}x{n}" for k, n in args.batch]]
    return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=path or os.getcwd())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[3, 10, 32, 64])
    parser.add_argument("--batch", type=lambda s: tuple(map(int, s.split("x"))), nargs="+", default=[(64, 3), (4, 64)])
    parser.add_argument("--rounds", type=int, default=12)
    parser.add_argument("--clock", choices=["wall", "cpu"], default="cpu")
    parser.add_argument("--baseline", type=str, default=None, help="another checkout, run in its own worker")
    parser.add_argument("--json", type=str, default=None)
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    here = str(HERE.parent.parent)
    sides = {"this": start_worker(here, args)}
    if args.baseline:
        sides["baseline"] = start_worker(str(Path(args.baseline).resolve()), args)
    for proc in sides.values():
        json.loads(proc.stdout.readline())
    best: dict[str, dict[str, float]] = {side: {} for side in sides}
    order = list(sides)
    for r in range(args.rounds):
        for side in order if r % 2 == 0 else order[::-1]:
            proc = sides[side]
            proc.stdin.write("round\n")
            proc.stdin.flush()
            for name, (agent_steps, seconds) in json.loads(proc.stdout.readline()).items():
                cost = seconds / agent_steps * 1e6
                best[side][name] = min(best[side].get(name, float("inf")), cost)
    for proc in sides.values():
        proc.stdin.close()
        proc.wait()
    names = list(best["this"])
    print(f"Navigation-v0, µs per agent-step (best chunk of {args.rounds} rounds, {args.clock} clock, {os.cpu_count()} cores)")
    header = f"{'case':<16} {'this':>9}" + (f" {'baseline':>9} {'this/base':>10}" if args.baseline else "")
    print(header)
    for name in names:
        line = f"{name:<16} {best['this'][name]:>9.2f}"
        if args.baseline:
            line += f" {best['baseline'][name]:>9.2f} {best['this'][name] / best['baseline'][name]:>9.3f}x"
        print(line)
    for side, costs in best.items():
        if "lone 64" in costs and "lone 10" in costs:
            print(f"{side}: lone 64 / lone 10 per agent-step: {costs['lone 64'] / costs['lone 10']:.3f}")
        for k, n in args.batch:
            if f"batch {k}x{n}" in costs:
                ratio = costs[f"batch {k}x{n}"] / costs[f"physics {k}x{n}"]
                print(f"{side}: batch {k}x{n} / physics-only loop of its spaces: {ratio:.2f}x")
    if args.json:
        Path(args.json).write_text(json.dumps({"clock": args.clock, "rounds": args.rounds, "us_per_agent_step": best}, indent=2))


if __name__ == "__main__":
    main()
