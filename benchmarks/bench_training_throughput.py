"""PPO training throughput (agent-steps/s) of teamgym envs, before and after, beside MPE2 ``simple_spread``.

Every case trains SB3 with ``baselines.train``'s settings for ``n_envs`` copies (rollouts of
about 2048 agent transitions in 8 mini-batches, 10 epochs, the default MLP, torch on one
thread in the training process) for ``--timesteps`` agent transitions, and reports
``model.num_timesteps / wall time`` of ``learn``. The algorithm is the one ``baselines.train``
accepts for the env's default action type: PPO, or sb3-contrib's MaskablePPO where the
actions are masked (``check_masks`` refuses PPO there: Foraging-v0, Rendezvous-v0).
The copies run in the training process (``--workers 1``:
:class:`~baselines.rl.sb3_env.TeamVecEnv`) or in worker processes
(:class:`~baselines.rl.subproc.SubprocTeamVecEnv`).

Each measurement runs in a fresh interpreter that imports ``teamgym`` and ``baselines`` from
one checkout (``PYTHONPATH``). Variants per env:

* ``after``: this checkout, ``batched=None`` (the default: copies stepped as one batch where
  the adapter can);
* ``per copy``: this checkout, ``batched=False`` (one copy at a time through the PettingZoo API);
* ``before``: the checkout ``--baseline DIR`` (an older commit), ``batched=None``.

Without ``--env`` the cases are today's: Navigation-v0 with ``--agents`` robots and MPE2's
``simple_spread`` with ``--agents`` agents (continuous actions, 25-step episodes; skipped
without ``mpe2``) through the same adapters; ``--env ID`` (repeatable) measures those ids
with their default config instead. Cases are interleaved over ``--rounds`` rounds (every
variant of one env and worker count back to back) and the best round of each is reported
(the least disturbed by other load). Wall clock only: the CPU time of one process misses
the worker processes. Quote ratios measured in one run.

    python benchmarks/bench_training_throughput.py [--env ID ...] [--baseline DIR]
        [--timesteps 20000] [--rounds 2] [--n-envs 4] [--workers 1 2] [--agents 3] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
MPE2 = "MPE2 simple_spread"
VARIANTS = ("before", "after", "per copy")


@dataclass(frozen=True)
class Case:
    """One measurement: an env (id or ``MPE2``) with its config, the checkout, ``batched`` and the algorithm."""

    env: str
    variant: str
    checkout: str
    batched: bool | None
    algo: str
    config: dict[str, Any] = field(default_factory=dict)


def env_factory(env: str, config: dict[str, Any]) -> Callable[[], Any]:
    """A function that makes one copy of ``env`` (a teamgym id or ``MPE2``) with ``config``."""
    if env == MPE2:
        from mpe2 import simple_spread_v3

        return lambda: simple_spread_v3.parallel_env(**config, continuous_actions=True)
    import teamgym

    return lambda: teamgym.make(env, **config)


def measure(case: Case, n_envs: int, workers: int, timesteps: int) -> dict[str, Any]:
    """(Run in a worker interpreter.) Agent-steps/s and padding share of ``case`` trained for ``timesteps``."""
    import torch

    import teamgym
    from baselines.rl.sb3_env import TeamVecEnv
    from baselines.rl.sb3_policy import algorithm_class
    from baselines.rl.subproc import SubprocTeamVecEnv
    from baselines.rl.train import default_hyperparameters

    torch.set_num_threads(1)
    env_fn = env_factory(case.env, case.config)
    if workers == 1:
        venv = TeamVecEnv(env_fn, n_envs=n_envs, batched=case.batched)
    else:
        venv = SubprocTeamVecEnv(env_fn, n_envs, n_workers=workers, batched=case.batched)
    hyperparameters = default_hyperparameters(case.algo, venv.num_envs)
    model = algorithm_class(case.algo)("MlpPolicy", venv, seed=0, device="cpu", verbose=0, **hyperparameters)
    start = time.perf_counter()
    model.learn(timesteps)
    rate = model.num_timesteps / (time.perf_counter() - start)
    result = {"rate": rate, "padding_share": venv.padding_share, "batched": getattr(venv, "batched", None)}
    venv.close()
    return {**result, "teamgym": str(Path(teamgym.__file__).parents[1])}


def run_case(case: Case, args: argparse.Namespace, workers: int) -> dict[str, Any]:
    """:func:`measure` in a fresh interpreter that imports teamgym and baselines from ``case.checkout``."""
    command = [sys.executable, __file__, "--case", json.dumps(asdict(case))]
    command += ["--timesteps", str(args.timesteps), "--n-envs", str(args.n_envs), "--workers", str(workers)]
    path = os.pathsep.join([case.checkout, os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    environment = {**os.environ, "PYTHONPATH": path, "SDL_VIDEODRIVER": os.environ.get("SDL_VIDEODRIVER", "dummy")}
    done = subprocess.run(command, env=environment, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{case.env} ({case.variant}, {workers} workers) failed:\n{done.stderr.strip()}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    if Path(result["teamgym"]).resolve() != Path(case.checkout).resolve():
        raise SystemExit(f"{case.variant} imported teamgym from {result['teamgym']}, not {case.checkout}")
    return result


def algorithm_for(env_id: str) -> str:
    """``baselines.train``'s choice for ``env_id``'s default action type: ppo, or maskable_ppo where actions are masked."""
    import teamgym
    from baselines.rl.sb3_policy import check_masks

    probe = teamgym.make(env_id)
    try:
        check_masks("ppo", probe)
        return "ppo"
    except ValueError:
        return "maskable_ppo"
    finally:
        probe.close()


def build_cases(args: argparse.Namespace) -> list[Case]:
    """Every case of the run, grouped by env; within an env: before, after, per copy."""
    here = str(ROOT)
    base = str(args.baseline.resolve()) if args.baseline else None
    envs = [(env_id, {}) for env_id in dict.fromkeys(args.env)] if args.env else [("Navigation-v0", {"n_robots": args.agents})]
    cases = []
    for env_id, config in envs:
        algo = algorithm_for(env_id)
        if base:
            cases.append(Case(env_id, "before", base, None, algo, config))
        cases.append(Case(env_id, "after", here, None, algo, config))
        cases.append(Case(env_id, "per copy", here, False, algo, config))
    if not args.env:
        import importlib.util

        if importlib.util.find_spec("mpe2") is not None:
            cases.append(Case(MPE2, "after", here, None, "ppo", {"N": args.agents}))
        else:
            print(f"{MPE2}: n/a (mpe2 is not installed)")
    return cases


def commit(checkout: str) -> str | None:
    """The short commit of ``checkout`` (with ``+dirty`` when its tracked files differ), or None outside git."""
    try:
        head = subprocess.run(["git", "-C", checkout, "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True)
        dirty = subprocess.run(["git", "-C", checkout, "diff", "--quiet", "HEAD"], capture_output=True).returncode != 0
    except (OSError, subprocess.CalledProcessError):
        return None
    return head.stdout.strip() + ("+dirty" if dirty else "")


def ratio(top: float | None, bottom: float | None) -> str:
    return f"{top / bottom:.2f}x" if top and bottom else "-"


def report(rows: list[dict[str, Any]], args: argparse.Namespace) -> None:
    """The table: one line per env and worker count, the variants side by side, and their ratios."""
    best = {(r["env"], r["workers"], r["variant"]): r["agent_steps_per_s"] for r in rows}
    algos = {r["env"]: r["algo"] for r in rows}
    heads = " ".join(f"{v:>8}" for v in VARIANTS)
    print(f"{'env':<20} {'algo':<13} {'workers':>7} {heads} {'after/before':>12} {'after/per copy':>14}")
    for env in algos:
        for workers in args.workers:
            before, after, per_copy = (best.get((env, workers, v)) for v in VARIANTS)
            cells = " ".join(f"{v:8.0f}" if v else f"{'-':>8}" for v in (before, after, per_copy))
            print(f"{env:<20} {algos[env]:<13} {workers:>7} {cells} {ratio(after, before):>12} {ratio(after, per_copy):>14}")
    if (MPE2, args.workers[0], "after") in best:
        for workers in args.workers:
            teamgym_rate, mpe2_rate = best.get(("Navigation-v0", workers, "after")), best.get((MPE2, workers, "after"))
            print(f"teamgym Navigation-v0 / MPE2, workers={workers}: {ratio(teamgym_rate, mpe2_rate)}")


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", action="append", metavar="ID", help="env id (repeatable); default: Navigation-v0, MPE2")
    parser.add_argument("--baseline", type=Path, metavar="DIR", help="an older checkout, measured as 'before'")
    parser.add_argument("--timesteps", type=int, default=20_000, help="agent transitions per training run")
    parser.add_argument("--rounds", type=int, default=2, help="interleaved rounds; the best is reported")
    parser.add_argument("--n-envs", type=int, default=4, help="env copies")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker process counts (1: in-process)")
    parser.add_argument("--agents", type=int, default=3, help="robots of Navigation-v0 and agents of MPE2 without --env")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the results here")
    parser.add_argument("--case", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    for flag in ("timesteps", "rounds", "n_envs", "agents"):
        if getattr(args, flag) < 1:
            parser.error(f"--{flag.replace('_', '-')} must be >= 1, got {getattr(args, flag)}")
    bad_workers = [w for w in args.workers if not 1 <= w <= args.n_envs]
    if bad_workers:
        parser.error(f"--workers must each be in [1, --n-envs={args.n_envs}], got {bad_workers}")
    if args.case:
        return args
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))  # this checkout's teamgym, not an installed one
    import teamgym

    unknown = [env_id for env_id in args.env or [] if env_id not in teamgym.envs()]
    if unknown:
        parser.error(f"--env: unknown env id(s) {unknown}; choose from {list(teamgym.envs())}")
    if args.baseline is not None and not all((args.baseline / pkg / "__init__.py").is_file() for pkg in ("teamgym", "baselines")):
        parser.error(f"--baseline {args.baseline} holds no teamgym and baselines packages")
    if args.json is not None and not args.json.parent.is_dir():
        parser.error(f"--json {args.json}: no directory {args.json.parent}")
    return args


def main(argv: Sequence[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    if args.case:
        print(json.dumps(measure(Case(**json.loads(args.case)), args.n_envs, args.workers[0], args.timesteps)))
        return
    cases = build_cases(args)
    commits = {c.checkout: commit(c.checkout) for c in cases}  # before the run: what was measured
    runs: dict[tuple[str, str, int], list[dict[str, Any]]] = {}
    for _ in range(args.rounds):
        for env in dict.fromkeys(c.env for c in cases):
            for workers in args.workers:
                for case in (c for c in cases if c.env == env):
                    runs.setdefault((env, case.variant, workers), []).append(run_case(case, args, workers))
    rows = []
    for case in cases:
        for workers in args.workers:
            results = runs[(case.env, case.variant, workers)]
            top = max(results, key=lambda r: r["rate"])
            rows.append(
                {
                    "env": case.env,
                    "variant": case.variant,
                    "algo": case.algo,
                    "workers": workers,
                    "agent_steps_per_s": top["rate"],
                    "rounds_agent_steps_per_s": [r["rate"] for r in results],
                    "padding_share": top["padding_share"],
                    "batched": top["batched"],
                    "checkout": case.checkout,
                    "commit": commits[case.checkout],
                }
            )
    machine = f"{platform.machine()}, {os.cpu_count()} cores"
    print(f"PPO agent-steps/s, {args.n_envs} env copies, best of {args.rounds} x {args.timesteps}, wall clock ({machine})")
    for variant in VARIANTS:
        checkout = next((r["checkout"] for r in rows if r["variant"] == variant), None)
        if checkout:
            print(f"  {variant}: {checkout} ({commits[checkout]})" + (", batched=False" if variant == "per copy" else ""))
    report(rows, args)
    if args.json:
        setting = {key: getattr(args, key) for key in ("timesteps", "rounds", "n_envs", "workers", "agents")}
        payload = {"command": " ".join(["python", "benchmarks/bench_training_throughput.py", *argv]), "machine": machine}
        args.json.write_text(json.dumps({**payload, "setting": setting, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
