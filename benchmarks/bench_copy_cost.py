"""What a copy of an env costs mid-episode, as the episode grows (issue 23).

Per env: one episode with random actions (admissible ones where masked; seeded), and at
each checkpoint step ``pickle.dumps`` + ``pickle.loads`` of the env, ``copy.deepcopy`` of
it (best of ``--repeats``, wall seconds or ``--clock cpu``) and the pickled size. Where the
env re-bases (``rebase_cycles``), the same is timed again at the last step before the next
base, where a copy replays the most. Episodes are kept alive: a large ``max_cycles``
(Foraging: ``time_limit``), Exploration with door D3,4 closed (sector S4, behind it, is
never explored) and Rendezvous with ``velocity`` actions (one control cycle a step; a
``next_place`` step lasts about 50 cycles, so 20,000 of them would be a million cycles:
``--set Rendezvous-v0.action_type=next_place`` runs them). Otherwise only public APIs are
used, so the script also times other versions of the package
(``PYTHONPATH=<checkout> python benchmarks/bench_copy_cost.py``).

    python benchmarks/bench_copy_cost.py [--steps 20000] [--at 100 1000 20000] [--envs ...]
        [--repeats 3] [--clock wall|cpu] [--seed 1] [--set ENV.key=value ...] [--json FILE]
"""

from __future__ import annotations

import argparse
import copy
import json
import pickle
import time
from collections.abc import Callable

import numpy as np

import teamgym
from teamgym.envs.config import parse_value

ENVS = ("Navigation-v0", "Exploration-v0", "Rendezvous-v0", "Foraging-v0", "BoxPushing-v0", "BoxPushing-v1")
#: Config per env: long enough episodes; Rendezvous with single-cycle steps (see the module docstring).
CONFIGS: dict[str, dict] = {env_id: {"max_cycles": 10**8} for env_id in ENVS}
CONFIGS["Rendezvous-v0"]["action_type"] = "velocity"
CONFIGS["Foraging-v0"]["time_limit"] = 100_000.0
CONFIGS["Exploration-v0"].update(closed_doors=("D3,4",), start_sectors=("S1", "S2", "S3"))


def random_action(env, agent: str, infos: dict, rng: np.random.Generator):
    space, mask = env.action_space(agent), infos.get(agent, {}).get("action_mask")
    if mask is not None:
        return int(rng.choice(np.flatnonzero(mask)))
    if hasattr(space, "n"):
        return int(rng.integers(space.start, space.start + space.n))
    return rng.uniform(space.low, space.high).astype(space.dtype)


def best_time(fn: Callable[[], object], repeats: int, clock: Callable[[], float]) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = clock()
        fn()
        best = min(best, clock() - start)
    return best


def timings(env, repeats: int, clock: Callable[[], float]) -> dict:
    return {
        "step_cycles": env.cycles,
        "pickle_s": best_time(lambda: pickle.loads(pickle.dumps(env)), repeats, clock),
        "deepcopy_s": best_time(lambda: copy.deepcopy(env), repeats, clock),
        "size_kB": len(pickle.dumps(env)) / 1e3,
    }


def measure(env_id: str, config: dict, checkpoints: list[int], repeats: int, clock: Callable[[], float], seed: int) -> list[dict]:
    env = teamgym.make(env_id, **config)
    rng = np.random.default_rng(seed)
    _, infos = env.reset(seed=seed)
    rows, steps, last_step = [], 0, 1

    def step() -> None:
        nonlocal infos, steps, last_step
        cycles = env.cycles
        _, _, _, _, infos = env.step({a: random_action(env, a, infos, rng) for a in env.agents})
        steps, last_step = steps + 1, env.cycles - cycles

    for target in checkpoints:
        while steps < target and env.agents:
            step()
        if steps < target:
            rows.append({"env": env_id, "step": target, "ended_at": steps})
            break
        row = {"env": env_id, "step": steps, **timings(env, repeats, clock)}
        every = getattr(env, "rebase_cycles", None)
        if every is not None and hasattr(env, "_cycles_since_base"):
            while env.agents and env._cycles_since_base() + last_step < every:
                step()
            if env.agents:
                row["before_base"] = {"step": steps, **timings(env, repeats, clock)}
        rows.append(row)
    return rows


def parse_sets(items: list[str]) -> dict[str, dict]:
    out: dict[str, dict] = {}
    for item in items:
        target, sep, value = item.partition("=")
        env_id, dot, key = target.rpartition(".")
        if not (sep and dot and env_id in ENVS and key):
            raise SystemExit(f"--set wants ENV.key=value with ENV one of {list(ENVS)}, got {item!r}")
        out.setdefault(env_id, {})[key] = parse_value(value)
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=20000, help="last checkpoint (steps into the episode)")
    parser.add_argument("--at", type=int, nargs="+", default=[100, 1000, 20000], help="checkpoints (steps; capped at --steps)")
    parser.add_argument("--envs", nargs="+", default=list(ENVS), choices=ENVS)
    parser.add_argument("--repeats", type=int, default=3, help="timings per checkpoint (the best is kept)")
    parser.add_argument("--clock", choices=["wall", "cpu"], default="wall")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="ENV.key=value")
    parser.add_argument("--json", help="also write the rows to this file")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    checkpoints = sorted({min(s, args.steps) for s in args.at if s >= 1} | {args.steps})
    clock = time.perf_counter if args.clock == "wall" else time.process_time
    sets = parse_sets(args.sets)
    rows = []
    print(f"{'env':15s} {'step':>6s} {'cycles':>8s} {'pickle+load s':>14s} {'deepcopy s':>11s} {'pickled kB':>11s}")
    for env_id in args.envs:
        config = {**CONFIGS[env_id], **sets.get(env_id, {})}
        for row in measure(env_id, config, checkpoints, args.repeats, clock, args.seed):
            rows.append(row)
            if "ended_at" in row:
                print(f"{env_id:15s} episode ended at step {row['ended_at']} (before {row['step']})")
                continue
            for label, r in (("", row), (" (last step before a base)", row.get("before_base"))):
                if r is not None:
                    print(
                        f"{env_id:15s} {r['step']:6d} {r['step_cycles']:8d} {r['pickle_s']:14.3f} {r['deepcopy_s']:11.3f} "
                        f"{r['size_kB']:11.1f}{label}",
                        flush=True,
                    )
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"clock": args.clock, "repeats": args.repeats, "rows": rows}, handle, indent=1)


if __name__ == "__main__":
    main()
