"""Agent-steps/s of ``teamgym.make_batch`` against one lone env, for every env id (issue 24).

For each id (default config, its default action type): a lone env stepped through the
PettingZoo API, and batches of K copies (``--copies``) stepped with arrays, in one process,
interleaved in rounds; the best round of each case is kept (the least disturbed on a shared
machine) and the ratios are taken within this one run. Actions: uniform in a Box space; for a
discrete space the first admissible action of each robot (so masked types stay legal); the
same rule for the lone env and the batch. Every case steps ``--steps`` times from a reset (a
batch's copies then cover the same stretch of their episodes as the lone env); episodes that
end are reset (lone) or auto-reset (batch) and count. ``--clock cpu`` (the default) times process CPU.

``--baseline DIR`` also times another checkout (its ``teamgym`` imported from ``DIR`` in a
child process running this script), round by round interleaved with this tree's, and prints
this/baseline per case; a case the checkout cannot build (an id without a batch form there)
is left out.

    python benchmarks/bench_batch_every_env.py [--envs ...] [--copies 1 16 64] [--steps 64] [--rounds 3]
        [--baseline DIR] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from gymnasium import spaces

import teamgym

CLOCKS = {"cpu": time.process_time, "wall": time.perf_counter}


def _choose(space: spaces.Space, rng: np.random.Generator, masks: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray:
    if isinstance(space, spaces.Discrete):
        if masks is None:
            return np.zeros(shape, dtype=np.int64)
        return np.argmax(masks, axis=-1)
    if isinstance(space, spaces.MultiDiscrete):
        return np.zeros((*shape, len(space.nvec)), dtype=np.int64)
    return rng.uniform(space.low, space.high, size=(*shape, *space.shape)).astype(space.dtype)


def time_lone(env_id: str, steps: int, clock) -> float:
    """Agent-steps/s of one env through ``step(dict)``."""
    env = teamgym.make(env_id)
    env.reset(seed=0)
    space = env.action_space(env.possible_agents[0])
    rng = np.random.default_rng(0)
    agent_steps, start = 0, clock()
    for _ in range(steps):
        if not env.agents:
            env.reset()
        masks = env.action_masks() if space.__class__ is spaces.Discrete else {}
        actions = {}
        for agent in env.agents:
            mask = masks.get(agent)
            actions[agent] = _choose(space, rng, None if mask is None else mask[None], (1,))[0]
            if isinstance(space, spaces.Discrete):
                actions[agent] = int(actions[agent])
        agent_steps += len(actions)
        env.step(actions)
    return agent_steps / (clock() - start)


def time_batch(env_id: str, copies: int, steps: int, clock) -> float:
    """Agent-steps/s of ``make_batch(env_id, copies, auto_reset=True)`` through ``step(array)``."""
    try:
        batch, by_hand = teamgym.make_batch(env_id, copies, auto_reset=True), False
    except (TypeError, ValueError):  # a checkout whose batch has no auto_reset: finished copies are reset here
        batch, by_hand = teamgym.make_batch(env_id, copies), True
    batch.reset(seed=0)
    rng = np.random.default_rng(0)
    shape = (batch.n_copies, batch.n_robots)
    agent_steps, start = 0, clock()
    for _ in range(steps):
        if by_hand:
            for k in np.flatnonzero(batch.episode_over()).tolist():
                batch.reset_copy(k)
        agent_steps += int(batch.active.sum())
        masks = batch.action_masks() if hasattr(batch, "action_masks") else None  # older batches had no masks
        batch.step(_choose(batch.action_space, rng, masks, shape))
    return agent_steps / (clock() - start)


def measure_round(env_id: str, copies: list[int], steps: int, clock, older: bool = False) -> dict[str, float]:
    """One round of every case of ``env_id``: agent-steps/s by case name.

    ``older``: the checkout is a baseline, whose batches an id may lack; those cases are left out
    (in this tree every error propagates).
    """
    rates = {"lone": time_lone(env_id, steps, clock)}
    _warm_up(env_id, max(copies, default=0), older)
    for k in copies:
        try:
            rates[f"batch {k}"] = time_batch(env_id, k, steps, clock)
        except (ValueError, NotImplementedError, AttributeError, TypeError):
            if not older:
                raise
    return rates


def _warm_up(env_id: str, copies: int, older: bool) -> None:
    """One untimed step of a batch of ``copies``: the process loads the compiled kernel and runs its checks here.

    Every baseline round is a fresh process; without this its first timed batch would pay
    that start-up (about 0.4 s) and a checkout with the kernel would look slower than it is.
    """
    try:
        batch = teamgym.make_batch(env_id, copies)
    except (ValueError, NotImplementedError, AttributeError, TypeError):
        if not older:
            raise
        return
    batch.reset(seed=0)
    masks = batch.action_masks() if hasattr(batch, "action_masks") else None
    batch.step(_choose(batch.action_space, np.random.default_rng(0), masks, (batch.n_copies, batch.n_robots)))


def baseline_round(directory: str, env_id: str, args: argparse.Namespace) -> dict[str, float]:
    """One round of ``env_id`` with ``teamgym`` from the checkout ``directory`` (a child process running this script)."""
    with tempfile.TemporaryDirectory() as scratch:
        out = os.path.join(scratch, "round.json")
        command = [sys.executable, os.path.abspath(__file__), "--envs", env_id, "--copies", *map(str, args.copies)]
        command += ["--steps", str(args.steps), "--rounds", "1", "--clock", args.clock, "--json", out, "--as-baseline"]
        environment = {**os.environ, "PYTHONPATH": os.path.abspath(directory)}
        subprocess.run(command, check=True, env=environment, cwd=scratch)
        with open(out) as handle:
            return json.load(handle)["agent_steps_per_s"][env_id]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", nargs="+", default=teamgym.envs())
    parser.add_argument("--copies", nargs="+", type=int, default=[1, 16, 64])
    parser.add_argument("--steps", type=int, default=64, help="steps from reset per copy, per case and round (the same for all)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu")
    parser.add_argument("--baseline", help="another checkout (its root), timed in a child process, interleaved")
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--as-baseline", action="store_true", help=argparse.SUPPRESS)  # the child of --baseline
    args = parser.parse_args()
    unknown = [e for e in args.envs if e not in teamgym.envs()]
    if unknown or min(args.copies) < 1 or args.steps < 1 or args.rounds < 1:
        parser.error(f"unknown env ids {unknown}" if unknown else "--copies, --steps and --rounds must be >= 1")
    if args.baseline and not os.path.isdir(os.path.join(args.baseline, "teamgym")):
        parser.error(f"--baseline {args.baseline!r} is not a checkout (no teamgym/ in it)")
    clock = CLOCKS[args.clock]
    results: dict[str, dict[str, float]] = {}
    baseline: dict[str, dict[str, float]] = {}
    for env_id in args.envs:
        best: dict[str, float] = {}
        before: dict[str, float] = {}
        for _ in range(args.rounds):
            for name, rate in measure_round(env_id, args.copies, args.steps, clock, args.as_baseline).items():
                best[name] = max(best.get(name, 0.0), rate)
            if args.baseline:
                for name, rate in baseline_round(args.baseline, env_id, args).items():
                    before[name] = max(before.get(name, 0.0), rate)
        results[env_id] = best
        if before:
            baseline[env_id] = before
        lone = best["lone"]
        if not args.as_baseline:
            cells = "  ".join(f"{name}: {rate:9.0f} ({rate / lone:4.2f}x)" for name, rate in best.items())
            print(f"{env_id:16s} {cells}", flush=True)
            if before:
                cells = "  ".join(f"{name}: {best[name] / rate:4.2f}x" for name, rate in before.items() if name in best)
                print(f"{'  this/baseline':16s} {cells}", flush=True)
    if args.json:
        with open(args.json, "w") as handle:
            record = {"clock": args.clock, "steps": args.steps, "rounds": args.rounds, "agent_steps_per_s": results}
            if args.baseline:
                record["baseline"] = {"checkout": os.path.abspath(args.baseline), "agent_steps_per_s": baseline}
            json.dump(record, handle, indent=2)


if __name__ == "__main__":
    main()
