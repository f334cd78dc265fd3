"""RLlib's vector env: K teamgym copies stepped as one ``make_batch`` batch vs RLlib's own loop over copies.

Times the env side of an RLlib env runner's sample (``VectorMultiAgentEnv.step`` with the same
random admissible actions, auto-resets included) for ``baselines.rl.rllib_batch.TeamVectorMultiAgentEnv``
and RLlib's ``SyncVectorMultiAgentEnv`` of ``TeamMultiAgentEnv`` copies, in one process, in
alternating blocks (CPU clock). Prints agent-steps/s of each and their ratio per env id.
Needs ray[rllib] (run with the RLlib venv, e.g. ``build/venv-rllib/bin/python``)::

    python benchmarks/bench_rllib_vector.py [--env Navigation-v0 ...] [--copies 16] [--steps 200] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

DEFAULT_ENVS = ("Navigation-v0", "BoxPushing-v0", "BoxPushing-v1", "Exploration-v0", "Foraging-v0", "Rendezvous-v0")


def _actions(vector, observations, rng):
    space = next(iter(vector.single_action_spaces.values()))
    out = []
    for obs in observations:
        acts = {}
        for agent, o in obs.items():
            if isinstance(o, dict):
                acts[agent] = int(rng.choice(np.flatnonzero(o["action_mask"])))
            elif hasattr(space, "n"):
                acts[agent] = int(rng.integers(space.n))
            else:
                acts[agent] = rng.uniform(space.low, space.high).astype(space.dtype)
        out.append(acts)
    return out


def _block(vector, observations, steps, seed):
    """``steps`` vector steps; returns (agent steps, CPU seconds, last observations)."""
    rng = np.random.default_rng(seed)
    agent_steps, spent = 0, 0.0
    for _ in range(steps):
        actions = _actions(vector, observations, rng)
        begin = time.process_time()
        observations = vector.step(actions)[0]
        spent += time.process_time() - begin
        agent_steps += sum(len(a) for a in actions)
    return agent_steps, spent, observations


def main() -> None:
    from ray.rllib.env.vector.sync_vector_multi_agent_env import SyncVectorMultiAgentEnv

    from baselines.rl.rllib import TeamMultiAgentEnv
    from baselines.rl.rllib_batch import TeamVectorMultiAgentEnv

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", action="append", default=None)
    parser.add_argument("--copies", type=int, default=16)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", default=None, help="write the results to this file")
    args = parser.parse_args()
    results = {}
    for env_id in args.env or DEFAULT_ENVS:
        spec = {"env_id": env_id, "config": {}}
        if env_id == "Exploration-v0":
            spec["config"] = {"action_type": "operator"}
        vectors = {
            "rllib loop": SyncVectorMultiAgentEnv([lambda spec=spec: TeamMultiAgentEnv(spec) for _ in range(args.copies)]),
            "teamgym batch": TeamVectorMultiAgentEnv(spec, args.copies),
        }
        totals = {name: [0, 0.0] for name in vectors}
        observations = {name: v.reset(seed=0)[0] for name, v in vectors.items()}
        for r in range(args.rounds):
            order = list(vectors) if r % 2 == 0 else list(reversed(vectors))
            for name in order:
                n, spent, observations[name] = _block(vectors[name], observations[name], args.steps, r)
                totals[name][0] += n
                totals[name][1] += spent
        rates = {name: n / spent for name, (n, spent) in totals.items()}
        ratio = rates["teamgym batch"] / rates["rllib loop"]
        results[env_id] = {**{k: round(v) for k, v in rates.items()}, "ratio": round(ratio, 3)}
        print(
            f"{env_id:16s} rllib loop {rates['rllib loop']:9.0f}  teamgym batch {rates['teamgym batch']:9.0f} "
            f"agent-steps/s  ratio {ratio:.2f}x  ({args.copies} copies)",
            flush=True,
        )
        for v in vectors.values():
            v.close()
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"copies": args.copies, "steps": args.steps, "rounds": args.rounds, "results": results}, f, indent=1)


if __name__ == "__main__":
    main()
