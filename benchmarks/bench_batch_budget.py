"""What issue 24's "64 copies ≥ 3× one lone env" leaves for Python, per env, beside Chipmunk's own share.

A batch steps every copy's pymunk space with the same substeps as a lone env (copies are
bit-identical to lone envs), so Chipmunk's work per copy and control step is a floor that no
batching removes. For each env id (default config) this script times, in one process and
interleaved over ``--rounds`` rounds (process CPU time, best round):

* **lone**: one lone env through ``step(dict)`` (``bench_batch_phases.lone_run``'s action rule),
  in µs per control step (a macro step of Rendezvous or Exploration's operators runs several);
* **batch**: ``teamgym.make_batch(env_id, K)`` with the same action rule, in µs per copy and
  control step;
* **physics**: the part of the batch's step spent in its worlds' substeps (``World._integrate``:
  Chipmunk's ``cpSpaceStep`` and the contact callbacks it calls; with the compiled kernel,
  ``WorldsKernel.step``, which also makes the control bodies' setter calls and the body reads
  around the substeps), timed in a second pass of the same rollout, in µs per copy and control step.

Control steps are counted (``World._integrate`` calls, and one per world of each
``WorldsKernel.step``) in a first pass of the same rollouts; the timed lone and batch passes run
unwatched.
It prints the ratio batch/lone in agent-steps/s (what the aim measures), the ceiling
``lone / physics`` (the ratio a batch whose Python cost nothing would reach), and the Python
(and ray-query) time per copy-step the 3× aim leaves, ``lone / 3 − physics``, beside what the
batch spends on it now, ``batch − physics``.

    python benchmarks/bench_batch_budget.py [--envs ID ...] [--copies 64] [--steps 32] [--rounds 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_batch_phases import _actions, lone_run  # noqa: E402

import teamgym  # noqa: E402
from teamgym.sim.kernel import WorldsKernel  # noqa: E402
from teamgym.sim.world import World  # noqa: E402


def watch_substeps(run) -> tuple[int, float, object]:
    """``run()`` with the substeps watched (``World._integrate``, ``WorldsKernel.step``): control steps, CPU s inside, result."""
    originals = World._integrate, WorldsKernel.step
    calls, spent = [0], [0.0]

    def watching(original, worlds_of):
        def watched(self, *args):
            calls[0] += worlds_of(self)
            start = time.process_time()
            try:
                return original(self, *args)
            finally:
                spent[0] += time.process_time() - start

        return watched

    World._integrate = watching(originals[0], lambda world: 1)
    WorldsKernel.step = watching(originals[1], lambda kernel: len(kernel.layouts))
    try:
        result = run()
    finally:
        World._integrate, WorldsKernel.step = originals
    return calls[0], spent[0], result


def batch_run(env_id: str, copies: int, steps: int):
    """A new batch (auto-reset) and a function that resets it (seed 0) and steps it ``steps`` times: (agent-steps, seconds)."""
    batch = teamgym.make_batch(env_id, copies, auto_reset=True)

    def run() -> tuple[int, float]:
        batch.reset(seed=0)
        rng = np.random.default_rng(0)
        agent_steps, start = 0, time.process_time()
        for _ in range(steps):
            agent_steps += int(batch.active.sum())
            batch.step(_actions(batch, rng))
        return agent_steps, time.process_time() - start

    return batch, run


def measure(env_id: str, copies: int, steps: int, rounds: int) -> dict:
    """Best-of-``rounds`` figures of one env (see the module docstring)."""
    lone_control, _, _ = watch_substeps(lambda: lone_run(env_id, steps))
    _, run = batch_run(env_id, copies, steps)
    batch_control, _, _ = watch_substeps(run)
    lone_rate = batch_rate = 0.0
    lone_us = batch_us = physics_us = float("inf")
    for _ in range(rounds):
        agent_steps, seconds = lone_run(env_id, steps)
        lone_rate, lone_us = max(lone_rate, agent_steps / seconds), min(lone_us, seconds / lone_control * 1e6)
        agent_steps, seconds = run()
        batch_rate, batch_us = max(batch_rate, agent_steps / seconds), min(batch_us, seconds / batch_control * 1e6)
        physics_us = min(physics_us, watch_substeps(run)[1] / batch_control * 1e6)
    return {
        "env": env_id,
        "copies": copies,
        "steps": steps,
        "control_steps_per_env_step": lone_control / steps,
        "lone_agent_steps_per_s": lone_rate,
        "batch_agent_steps_per_s": batch_rate,
        "batch_over_lone": batch_rate / lone_rate,
        "lone_us_per_control_step": lone_us,
        "batch_us_per_copy_control_step": batch_us,
        "physics_us_per_copy_control_step": physics_us,
        "ceiling": lone_us / physics_us,
        "python_budget_for_3x_us": lone_us / 3 - physics_us,
        "python_now_us": batch_us - physics_us,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", nargs="+", default=teamgym.envs())
    parser.add_argument("--copies", type=int, default=64)
    parser.add_argument("--steps", type=int, default=32)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    rows = []
    print(f"{args.copies} copies, {args.steps} steps, best of {args.rounds} rounds, process CPU time; µs per (copy) control step")
    print(f"{'env':16} {'batch/lone':>10} {'ceiling':>8} {'lone':>8} {'batch':>8} {'physics':>8} {'budget 3x':>10} {'now':>10}")
    for env_id in args.envs:
        row = measure(env_id, args.copies, args.steps, args.rounds)
        rows.append(row)
        print(
            f"{env_id:16} {row['batch_over_lone']:9.2f}x {row['ceiling']:7.2f}x {row['lone_us_per_control_step']:8.1f} "
            f"{row['batch_us_per_copy_control_step']:8.1f} {row['physics_us_per_copy_control_step']:8.1f} "
            f"{row['python_budget_for_3x_us']:10.1f} {row['python_now_us']:10.1f}",
            flush=True,
        )
    if args.json:
        setting = {"copies": args.copies, "steps": args.steps, "rounds": args.rounds, "clock": "process CPU"}
        command = "python benchmarks/bench_batch_budget.py " + " ".join(sys.argv[1:])
        machine = f"{platform.machine()}, {len(__import__('os').sched_getaffinity(0))} cores"
        args.json.write_text(
            json.dumps({"command": command, "machine": machine, "setting": setting, "rows": rows}, indent=1) + "\n"
        )


if __name__ == "__main__":
    main()
