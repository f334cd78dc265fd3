"""Lone-env step speed of Rendezvous-v0 and Exploration-v0, A/B against another checkout in one run.

Cases (default config unless named):

* ``rdv-next``: Rendezvous-v0, ``next_place`` macro actions, a random admissible slot per robot;
* ``rdv-astar``: Rendezvous-v0 with the ``bidir-astar`` protocol baseline (its required config);
* ``rdv-velocity``: Rendezvous-v0, ``action_type="velocity"``, uniform random (v, ω);
* ``exp-velocity``: Exploration-v0 (``velocity``), uniform random (v, ω);
* ``exp-operator``: Exploration-v0, ``action_type="operator"``, a random admissible operator.

Random actions come from ``numpy.random.default_rng(seed)`` of the episode, so every checkout
plays the same actions; with the same env code the rollouts are the same, which the script
checks (a SHA-256 over every observation and reward of each block) and reports. One worker
process per checkout; each round plays, for every case, ``--episodes`` episodes (seeds new in
every round, at most ``--max-steps`` env steps each) on every worker in turn (alternating
which goes first). Only ``env.step`` is timed (``--clock``: ``cpu``, the default, or
``wall``); the policy's time is not. Printed per case: agent-steps/s and µs per control cycle
of each checkout over all rounds, the ratio of the speeds (this checkout over the baseline)
and the range of the per-round ratios.

    python benchmarks/bench_map_envs_step.py [--baseline DIR] [--case rdv-next ...] [--rounds 5] [--episodes 1]
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path
from typing import Any

import numpy as np
from ab_workers import in_turn, serve, start_workers

ROOT = Path(__file__).resolve().parents[1]
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
#: case -> (env id, config, policy name or None for random actions)
CASES: dict[str, tuple[str, dict[str, Any], str | None]] = {
    "rdv-next": ("Rendezvous-v0", {}, None),
    "rdv-astar": ("Rendezvous-v0", {}, "bidir-astar"),
    "rdv-velocity": ("Rendezvous-v0", {"action_type": "velocity"}, None),
    "exp-velocity": ("Exploration-v0", {}, None),
    "exp-operator": ("Exploration-v0", {"action_type": "operator"}, None),
}
_MADE: dict = {}


def _random_action(env: Any, agent: str, info: dict, rng: np.random.Generator) -> Any:
    mask = info.get("action_mask")
    if mask is not None:
        return int(rng.choice(np.flatnonzero(mask)))
    space = env.action_space(agent)
    return rng.uniform(space.low, space.high).astype(space.dtype)


def play(request: dict) -> dict:
    """Worker job: episodes of ``case`` with ``seeds``; step time (s), agent-steps, control cycles and a digest."""
    import teamgym
    from baselines.registry import make_policy, required_config

    env_id, config, policy_name = CASES[request["case"]]
    if request["case"] not in _MADE:
        config = {**(required_config(policy_name) if policy_name else {}), **config}
        env = teamgym.make(env_id, **config)
        _MADE[request["case"]] = (env, make_policy(policy_name, env) if policy_name else None)
    env, policy = _MADE[request["case"]]
    tick, digest = CLOCKS[request["clock"]], hashlib.sha256()
    elapsed, agent_steps, cycles = 0.0, 0, 0
    for seed in request["seeds"]:
        observations, infos = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        if policy is not None:
            policy.reset(seed)
        for _ in range(request["max_steps"]):
            if not env.agents:
                break
            if policy is not None:
                actions = policy.act(observations, infos)
            else:
                actions = {a: _random_action(env, a, infos[a], rng) for a in env.agents}
            began = tick()
            observations, rewards, _, _, infos = env.step(actions)
            elapsed += tick() - began
            agent_steps += len(actions)
            for agent in sorted(observations):
                digest.update(np.ascontiguousarray(observations[agent]).tobytes())
                digest.update(np.float64(rewards[agent]).tobytes())
        cycles += env.unwrapped.cycles
    return {"seconds": elapsed, "agent_steps": agent_steps, "cycles": cycles, "digest": digest.hexdigest()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", nargs="+", default=list(CASES), choices=list(CASES), help="cases (default: all)")
    parser.add_argument("--baseline", type=Path, help="another checkout (e.g. of main) to time in the same run")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (default 5)")
    parser.add_argument("--episodes", type=int, default=1, help="episodes per case, checkout and round (default 1)")
    parser.add_argument("--max-steps", type=int, default=400, help="env steps per episode at most (default 400)")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu", help="CPU (default) or wall time")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        serve(play)
        return
    if min(args.rounds, args.episodes, args.max_steps) < 1:
        parser.error(f"need --rounds, --episodes, --max-steps >= 1, got {args.rounds}, {args.episodes}, {args.max_steps}")
    try:
        workers = start_workers(__file__, ROOT, args.baseline, [])
    except ValueError as error:
        parser.error(str(error))
    totals = {(w, c): [0.0, 0, 0] for w in range(len(workers)) for c in args.case}
    ratios: dict[str, list[float]] = {c: [] for c in args.case}
    same = dict.fromkeys(args.case, True)
    try:
        for r in range(args.rounds):
            seeds = list(range(r * args.episodes, (r + 1) * args.episodes))
            for case in args.case:
                request = {"case": case, "seeds": seeds, "max_steps": args.max_steps, "clock": args.clock}
                answers = in_turn(workers, r, request)
                for w, answer in answers.items():
                    total = totals[w, case]
                    total[0] += answer["seconds"]
                    total[1] += answer["agent_steps"]
                    total[2] += answer["cycles"]
                if len(workers) == 2:
                    speed = [answers[w]["agent_steps"] / answers[w]["seconds"] for w in (0, 1)]
                    ratios[case].append(speed[0] / speed[1])
                    same[case] &= answers[0]["digest"] == answers[1]["digest"]
    finally:
        for worker in workers:
            worker.close()
    print(f"lone env.step, {args.rounds} rounds x {args.episodes} episode(s) of <= {args.max_steps} steps ({args.clock} clock)")
    print("  " + "   ".join(f"[{w}] {worker.package}" for w, worker in enumerate(workers)))
    for case in args.case:
        line = f"  {case:<13}"
        speeds = []
        for w in range(len(workers)):
            seconds, agent_steps, cycles = totals[w, case]
            speeds.append(agent_steps / seconds)
            line += f" {speeds[-1]:9.0f} agent-steps/s {seconds / cycles * 1e6:7.1f} us/cycle |"
        if len(workers) == 2:
            low, high = min(ratios[case]), max(ratios[case])
            line += f" [0]/[1] {speeds[0] / speeds[1]:.2f}x (rounds {low:.2f}-{high:.2f})"
            line += ", same rollouts" if same[case] else ", ROLLOUTS DIFFER"
        print(line)


if __name__ == "__main__":
    main()
