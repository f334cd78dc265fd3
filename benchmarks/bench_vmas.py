"""Agent-steps/s of VMAS's navigation scenario beside Navigation-v0 batches, side by side in one run.

Cases (random actions from one fixed table of 64 joint actions, the same number of steps each):

* ``vmas 1 thread`` / ``vmas 2 threads``: VMAS's ``navigation`` scenario, ``--envs`` envs,
  ``--robots`` agents, ``device="cpu"``, continuous actions, ``torch.set_num_threads(1 or 2)``,
  each in a worker process of the VMAS venv (``.venv-vmas``, built by
  ``bash scripts/setup_vmas_venv.sh``; teamgym is not installed there);
* ``teamgym 64 x 1 proc``: ``teamgym.make_batch("Navigation-v0", 64, n_robots=3)`` in this process;
* ``teamgym 32 x 2 procs``: two worker processes of 32 copies each, stepped concurrently; their
  agent-steps are summed over the span from the first start to the last finish.

Clocks: process CPU time where the case is one thread (``vmas 1 thread``, ``64 x 1 proc``), wall
time where it uses two cores (``vmas 2 threads``, ``32 x 2 procs``); the JSON holds both clocks
of every case. Rounds interleave the cases (order rotated each round, a pause between cases so
that idle torch threads stop spinning); the best round of each is kept and ratios are taken
within this one run. Episodes never end: VMAS runs with ``max_steps=None`` (its navigation
``done`` only flags that every agent sits on its goal, and nothing resets; those flags are
counted), teamgym with ``max_cycles=10**6``; a teamgym robot that arrives leaves ``active``,
only active robots count as agent-steps, and a copy whose robots are all done is reset (counted).

What each simulates (VMAS 1.5.2, ``vmas/scenarios/navigation.py`` and ``vmas/simulator/core.py``):

* VMAS ``navigation``: holonomic point-mass agents (discs of radius 0.1, mass 1) whose action is
  a 2-D force in [-1, 1]²; no obstacles and, by default, no walls (``enforce_bounds=False``); one
  goal landmark per agent (not colliding). ``World(substeps=2)`` with ``dt = 0.1``: per substep
  the action forces plus a penalty force for each overlapping pair of discs (stiffness
  ``COLLISION_FORCE = 100`` on a softplus of the penetration with ``contact_margin = 1e-3``),
  then semi-implicit Euler with drag 0.25 applied once per step. Each agent casts a 12-ray lidar
  (range 0.35) against the other agents only. All of it is torch tensor code batched over envs.
* teamgym ``Navigation-v0`` (3 robots): differential-drive Khepera discs (27.5 mm radius, 80 g)
  driven through force-limited pivot and gear joints by (v, ω) commands, 2 convex-polygon
  obstacles moving and bouncing, a walled 2 m × 2 m arena; pymunk's rigid-body contact solver
  with 20 substeps of 5 ms per 0.1 s control step; an 8-ray proximity ring per robot; one pymunk
  space per copy, stepped one after the other, the numpy work shared over copies.

    python benchmarks/bench_vmas.py [--envs 64] [--robots 3] [--steps 300] [--rounds 5] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
VMAS_PYTHON = ROOT / ".venv-vmas" / "bin" / "python"
SETUP = "bash scripts/setup_vmas_venv.sh"
TABLE = 64  # distinct joint actions, cycled
PAUSE = 0.3  # s between cases (OpenMP threads spin for up to ~200 ms after a parallel region)


def _timed(run: Any) -> dict[str, float]:
    """Run ``run()`` (returns a dict of counts) and add its wall and CPU seconds and wall start/end."""
    wall, cpu = time.perf_counter(), time.process_time()
    counts = run()
    end = time.perf_counter()
    return {**counts, "wall": end - wall, "cpu": time.process_time() - cpu, "start": wall, "end": end}


def _serve(step_chunk: Any, read: Any, write: Any) -> None:
    """Answer ``"run"`` with one timed chunk until ``"quit"`` (the protocol of every worker)."""
    write({"ready": True})
    while (command := read()) != "quit":
        if command != "run":
            raise ValueError(f"unknown worker command {command!r}")
        write(_timed(step_chunk))


def vmas_worker(envs: int, robots: int, steps: int, threads: int, seed: int) -> None:
    """The VMAS case, run with the VMAS venv's Python; speaks JSON lines on stdin/stdout."""

    def write(message: dict) -> None:
        sys.stdout.write(json.dumps(message) + "\n")
        sys.stdout.flush()

    try:
        import torch
        import vmas
    except ImportError as error:
        write({"error": f"{error} (in {sys.executable})"})
        return
    torch.set_num_threads(threads)
    env = vmas.make_env(
        "navigation", num_envs=envs, device="cpu", continuous_actions=True, max_steps=None, seed=seed, n_agents=robots
    )
    env.reset()
    u_range = torch.tensor([agent.u_range for agent in env.agents], dtype=torch.float32).view(1, -1, 1, 1)
    generator = torch.Generator().manual_seed(seed)
    table = (torch.rand((TABLE, robots, envs, 2), generator=generator) * 2 - 1) * u_range

    def chunk() -> dict[str, float]:
        done = 0
        for t in range(steps):
            _, _, dones, _ = env.step(list(table[t % TABLE]))
            done += int(dones.sum())
        return {"agent_steps": steps * envs * robots, "done_flags": done, "resets": 0}

    write({"vmas": vmas.__version__, "torch": torch.__version__, "threads": torch.get_num_threads()})
    chunk()  # warm-up
    _serve(chunk, lambda: sys.stdin.readline().strip() or "quit", write)


def teamgym_chunk(copies: int, robots: int, steps: int, seed: int) -> Any:
    """A chunk of ``steps`` batch steps of ``copies`` Navigation-v0 copies (built here, warmed up)."""
    import numpy as np

    import teamgym

    batch = teamgym.make_batch("Navigation-v0", copies, n_robots=robots, max_cycles=10**6)
    batch.reset(seed=seed)
    space = batch.action_space
    table = np.random.default_rng(seed).uniform(space.low, space.high, size=(TABLE, copies, robots, 2)).astype(np.float32)
    resets = 0

    def chunk() -> dict[str, float]:
        nonlocal resets
        agent_steps, before = 0, resets
        for t in range(steps):
            agent_steps += int(batch.active.sum())
            batch.step(table[t % TABLE])
            for k in np.flatnonzero(batch.episode_over()):
                resets += 1
                batch.reset_copy(int(k), seed=seed + 1000 * resets)
        return {"agent_steps": agent_steps, "done_flags": 0, "resets": resets - before}

    chunk()  # warm-up
    return chunk


def teamgym_worker(conn: Any, copies: int, robots: int, steps: int, seed: int) -> None:
    """One process of the multi-process case; speaks over a multiprocessing pipe."""
    _serve(teamgym_chunk(copies, robots, steps, seed), conn.recv, conn.send)


class VmasCase:
    """A VMAS worker process in the VMAS venv."""

    def __init__(self, python: Path, args: argparse.Namespace, threads: int) -> None:
        worker = [str(python), str(Path(__file__).resolve()), "--vmas-worker", str(threads)]
        worker += ["--envs", str(args.envs), "--robots", str(args.robots), "--steps", str(args.steps), "--seed", str(args.seed)]
        env = {**os.environ, "OMP_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads)}
        self.proc = subprocess.Popen(worker, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
        self.info = self._read()
        if "error" in self.info:
            raise SystemExit(f"error: the VMAS venv cannot run VMAS: {self.info['error']}; rebuild it with {SETUP}")
        self._read()  # ready, after the warm-up

    def _read(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"error: the VMAS worker ({VMAS_PYTHON}) exited with {self.proc.wait()}; rebuild it with {SETUP}")
        return json.loads(line)

    def run(self) -> dict[str, float]:
        self.proc.stdin.write("run\n")
        self.proc.stdin.flush()
        return self._read()

    def close(self) -> None:
        self.proc.stdin.write("quit\n")
        self.proc.stdin.flush()
        self.proc.wait(timeout=60)


class LocalCase:
    """Copies in this process."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.chunk = teamgym_chunk(args.envs, args.robots, args.steps, args.seed)

    def run(self) -> dict[str, float]:
        return _timed(self.chunk)

    def close(self) -> None:
        pass


class ProcessesCase:
    """``processes`` worker processes of ``envs / processes`` copies each, started together per run."""

    def __init__(self, args: argparse.Namespace) -> None:
        import multiprocessing

        context = multiprocessing.get_context("spawn")
        share = args.envs // args.processes
        self.pipes, self.procs = [], []
        for i in range(args.processes):
            parent, child = context.Pipe()
            work = (child, share, args.robots, args.steps, args.seed + i)
            proc = context.Process(target=teamgym_worker, args=work, daemon=True)
            proc.start()
            self.pipes.append(parent)
            self.procs.append(proc)
        for pipe in self.pipes:
            pipe.recv()  # ready, after the warm-up

    def run(self) -> dict[str, float]:
        for pipe in self.pipes:
            pipe.send("run")
        parts = [pipe.recv() for pipe in self.pipes]
        start, end = min(p["start"] for p in parts), max(p["end"] for p in parts)
        total = {key: sum(p[key] for p in parts) for key in ("agent_steps", "done_flags", "resets", "cpu")}
        # wall: the span all processes together took; cpu: the sum of the processes' CPU seconds
        return {**total, "wall": end - start, "cpu_rates": sum(p["agent_steps"] / p["cpu"] for p in parts)}

    def close(self) -> None:
        for pipe in self.pipes:
            pipe.send("quit")
        for proc in self.procs:
            proc.join(timeout=60)


def measure(cases: dict[str, Any], rounds: int) -> dict[str, dict[str, float]]:
    """Best agent-steps/s per case and clock over interleaved rounds (order rotated), with counts."""
    best: dict[str, dict[str, float]] = {name: {"wall": 0.0, "cpu": 0.0, "done_flags": 0, "resets": 0} for name in cases}
    names = list(cases)
    for r in range(rounds):
        for name in names[r % len(names) :] + names[: r % len(names)]:
            time.sleep(PAUSE)
            result = cases[name].run()
            entry = best[name]
            entry["wall"] = max(entry["wall"], result["agent_steps"] / result["wall"])
            # cpu of a multi-process case: the summed per-process CPU rates
            entry["cpu"] = max(entry["cpu"], result.get("cpu_rates", result["agent_steps"] / result["cpu"]))
            entry["done_flags"] += result["done_flags"]
            entry["resets"] += result["resets"]
    return best


def positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text}")
    return value


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=positive, default=64, help="VMAS envs = teamgym copies (default 64)")
    parser.add_argument("--robots", type=positive, default=3, help="agents per env (default 3)")
    parser.add_argument("--processes", type=positive, default=2, help="processes of the multi-process case (default 2)")
    parser.add_argument("--steps", type=positive, default=300, help="steps per timed chunk (default 300)")
    parser.add_argument("--rounds", type=positive, default=5, help="interleaved rounds (default 5)")
    parser.add_argument("--threads", type=positive, nargs="+", default=[1, 2], help="torch threads per VMAS case (default 1 2)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--vmas-python", type=Path, default=VMAS_PYTHON, help="Python of the VMAS venv (default .venv-vmas)")
    parser.add_argument("--json", type=str, default=None, help="also write the results to this file")
    parser.add_argument("--vmas-worker", type=positive, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.envs % args.processes:
        parser.error(f"--envs ({args.envs}) must be divisible by --processes ({args.processes})")
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse(argv)
    if args.vmas_worker is not None:
        vmas_worker(args.envs, args.robots, args.steps, args.vmas_worker, args.seed)
        return
    if not args.vmas_python.is_file():
        raise SystemExit(f"error: no VMAS venv at {args.vmas_python}; build it with {SETUP}")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    share = args.envs // args.processes
    single, multi = f"teamgym {args.envs} x 1 proc", f"teamgym {share} x {args.processes} procs"
    clocks = {f"vmas {t} thread{'s' if t > 1 else ''}": "cpu" if t == 1 else "wall" for t in args.threads}
    clocks.update({single: "cpu", multi: "wall" if args.processes > 1 else "cpu"})
    cases: dict[str, Any] = {name: VmasCase(args.vmas_python, args, t) for name, t in zip(clocks, args.threads)}
    try:
        cases[single] = LocalCase(args)
        cases[multi] = ProcessesCase(args)
        best = measure(cases, args.rounds)
    finally:
        for case in cases.values():
            case.close()
    rates = {name: best[name][clock] for name, clock in clocks.items()}
    vmas_names = [name for name in clocks if name.startswith("vmas")]
    ratios = {f"{team} / {v}": rates[team] / rates[v] for team in (single, multi) for v in vmas_names}
    info = cases[vmas_names[0]].info
    print(
        f"Navigation, {args.envs} envs x {args.robots} agents, random actions; best of {args.rounds} x {args.steps} steps, "
        f"interleaved ({platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}); "
        f"vmas {info['vmas']}, torch {info['torch']}"
    )
    print(f"{'case':<24} {'clock':>5} {'agent-steps/s':>14} {'(wall)':>10} {'(cpu)':>10} {'done flags':>11} {'resets':>7}")
    for name, clock in clocks.items():
        b = best[name]
        print(
            f"{name:<24} {clock:>5} {rates[name]:>14.0f} {b['wall']:>10.0f} {b['cpu']:>10.0f}"
            f" {b['done_flags']:>11} {b['resets']:>7}"
        )
    for name, ratio in ratios.items():
        print(f"{name}: {ratio:.2f}x")
    if args.json:
        out = {
            "envs": args.envs,
            "robots": args.robots,
            "processes": args.processes,
            "steps": args.steps,
            "rounds": args.rounds,
            "vmas": info["vmas"],
            "torch": info["torch"],
            "cores": os.cpu_count(),
            "load_1min": os.getloadavg()[0],
            "clock": clocks,
            "agent_steps_per_s": rates,
            "both_clocks": {name: {"wall": best[name]["wall"], "cpu": best[name]["cpu"]} for name in clocks},
            "done_flags": {name: best[name]["done_flags"] for name in clocks},
            "resets": {name: best[name]["resets"] for name in clocks},
            "ratios": ratios,
        }
        with open(args.json, "w") as handle:
            json.dump(out, handle, indent=2)


if __name__ == "__main__":
    main()
