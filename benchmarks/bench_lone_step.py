"""Agent-steps/s of one lone env per id (``step(dict)``), this tree against another checkout, in one run.

Each id (default config, its default action type; ``--config`` adds keys) runs ``--steps``
steps with actions from a fixed rule (uniform in a Box space, the first admissible action of
a masked discrete space, resets when the episode ends) in a fresh worker process per tree
and round; rounds alternate the trees and the best round of each is kept. Process CPU time.
With ``--baseline DIR`` the ratio this/baseline is printed per id: the claim "the lone env is
no slower than before" is a ratio ≥ 1 within noise (quote ratios from one run).

    python benchmarks/bench_lone_step.py [--baseline DIR] [--envs ...] [--steps 600] [--rounds 3] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

WORKER = r"""
import json, sys, time
import numpy as np
import teamgym
from gymnasium import spaces

env_id, steps = sys.argv[1], int(sys.argv[2])
env = teamgym.make(env_id)
env.reset(seed=0)
space = env.action_space(env.possible_agents[0])
rng = np.random.default_rng(0)
agent_steps, start = 0, time.process_time()
for _ in range(steps):
    if not env.agents:
        env.reset()
    masks = env.action_masks() if isinstance(space, spaces.Discrete) else {}
    actions = {}
    for agent in env.agents:
        if isinstance(space, spaces.Discrete):
            mask = masks.get(agent)
            actions[agent] = int(np.argmax(mask)) if mask is not None else 0
        elif isinstance(space, spaces.MultiDiscrete):
            actions[agent] = np.zeros(len(space.nvec), dtype=np.int64)
        else:
            actions[agent] = rng.uniform(space.low, space.high).astype(space.dtype)
    agent_steps += len(actions)
    env.step(actions)
print(json.dumps(agent_steps / (time.process_time() - start)))
"""


def run(tree: Path, env_id: str, steps: int) -> float:
    environment = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1", "SDL_VIDEODRIVER": "dummy"}
    done = subprocess.run(
        [sys.executable, "-c", WORKER, env_id, str(steps)], env=environment, capture_output=True, text=True, cwd="/"
    )
    if done.returncode:
        raise SystemExit(f"error: {env_id} failed in {tree}: {done.stderr.strip().splitlines()[-1]}")
    return float(done.stdout.strip().splitlines()[-1])


def main() -> None:
    here = Path(__file__).resolve().parents[1]
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", type=Path, help="another checkout (its root) to compare with")
    parser.add_argument("--envs", nargs="+")
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.steps < 1 or args.rounds < 1:
        parser.error("--steps and --rounds must be >= 1")
    if args.baseline is not None and not (args.baseline / "teamgym" / "__init__.py").is_file():
        parser.error(f"--baseline {args.baseline} is not a teamgym checkout (no teamgym/__init__.py)")
    sys.path.insert(0, str(here))
    import teamgym

    env_ids = args.envs or teamgym.envs()
    unknown = [e for e in env_ids if e not in teamgym.envs()]
    if unknown:
        parser.error(f"unknown env ids {unknown}")
    trees = {"this": here, **({"baseline": args.baseline.resolve()} if args.baseline else {})}
    results: dict[str, dict[str, float]] = {}
    for env_id in env_ids:
        best: dict[str, float] = {}
        for round_ in range(args.rounds):
            order = list(trees) if round_ % 2 == 0 else list(reversed(trees))
            for name in order:
                best[name] = max(best.get(name, 0.0), run(trees[name], env_id, args.steps))
        results[env_id] = best
        ratio = f"  this/baseline {best['this'] / best['baseline']:.3f}" if "baseline" in best else ""
        cells = "  ".join(f"{name} {rate:9.0f}" for name, rate in best.items())
        print(f"{env_id:16s} {cells}{ratio}", flush=True)
    if args.json:
        args.json.write_text(json.dumps({"steps": args.steps, "rounds": args.rounds, "agent_steps_per_s": results}, indent=2))


if __name__ == "__main__":
    main()
