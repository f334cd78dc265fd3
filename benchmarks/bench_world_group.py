"""A batch's physics phase with its worlds stepped together (``teamgym.sim.world_group``) or one by one, in one process.

For each env id: a ``teamgym.make_batch(env_id, K, auto_reset=True)`` batch is stepped a few
times, pickled, and every round restores it twice — once stepping with the shared physics
phase (:meth:`CopyPhases.physics <teamgym.envs.step_loop.CopyPhases.physics>`, worlds
together) and once with a physics phase that calls ``World.step`` world by world (the loop
before ``world_group``) — and steps ``--steps`` times with the same actions (uniform in a Box
space, the first admissible action of a masked discrete one). The rollouts are the same bit
for bit, so both cases do the same work; the order alternates every round and the fastest
round of each is kept (CPU clock). Ratio = time together / time one by one, within one run.

    python benchmarks/bench_world_group.py [--envs Navigation-v0 ...] [--copies 64] [--steps 20] [--rounds 6]
"""

from __future__ import annotations

import argparse
import pickle
import time

import numpy as np
from gymnasium import spaces

import teamgym
from teamgym.envs import step_loop
from teamgym.sim import world_group

TOGETHER = step_loop.CopyPhases.physics


def one_by_one(phases: step_loop.CopyPhases, group: list[int]) -> None:
    """The physics phase with every world stepped alone (``World.step``), trails recorded."""
    for k in group:
        env = phases.copies[k]
        env.world.step(reuse_states=phases.reuse_states)
        env.cycles += 1
        if env.records_trails:
            env._record_trails()


def actions(batch, rng: np.random.Generator) -> np.ndarray:
    space, rows = batch.action_space, (batch.n_copies, len(batch.copies[0].possible_agents))
    if isinstance(space, spaces.Discrete):
        masks = batch.action_masks()
        return np.argmax(masks, axis=-1) if masks is not None else np.zeros(rows, dtype=np.int64)
    return rng.uniform(space.low, space.high, size=(*rows, *space.shape)).astype(space.dtype)


def measure(env_id: str, copies: int, steps: int, rounds: int) -> dict[str, float]:
    batch = teamgym.make_batch(env_id, copies, auto_reset=True)
    batch.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(3):
        batch.step(actions(batch, rng))
    blob = pickle.dumps(batch)
    threshold = world_group.MIN_ROBOTS_TOGETHER
    best = {"together": float("inf"), "one by one": float("inf")}
    for r in range(rounds):
        order = [("together", TOGETHER), ("one by one", one_by_one)]
        for name, physics in order if r % 2 == 0 else order[::-1]:
            step_loop.CopyPhases.physics = physics
            world_group.MIN_ROBOTS_TOGETHER = 0 if name == "together" else threshold  # read when the copy is unpickled
            try:
                copy, rng = pickle.loads(blob), np.random.default_rng(1)
                start = time.process_time()
                for _ in range(steps):
                    copy.step(actions(copy, rng))
                best[name] = min(best[name], time.process_time() - start)
            finally:
                step_loop.CopyPhases.physics = TOGETHER
                world_group.MIN_ROBOTS_TOGETHER = threshold
    return {name: seconds / (steps * copies) * 1e6 for name, seconds in best.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", nargs="+", default=sorted(teamgym.envs()))
    parser.add_argument("--copies", type=int, default=64)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=6)
    args = parser.parse_args()
    print(f"{'env':<16} {'together':>12} {'one by one':>12}  µs per copy-step (CPU), {args.copies} copies")
    for env_id in args.envs:
        us = measure(env_id, args.copies, args.steps, args.rounds)
        ratio = us["together"] / us["one by one"]
        print(f"{env_id:<16} {us['together']:12.1f} {us['one by one']:12.1f}  together/one by one {ratio:.3f}")


if __name__ == "__main__":
    main()
