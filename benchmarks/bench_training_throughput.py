"""PPO training throughput (agent-steps/s) on teamgym beside MPE2 ``simple_spread``, 1 and 2 worker processes.

Every case trains SB3 PPO with the same settings (``baselines.train``'s defaults for
``n_envs`` copies: rollouts of about 2048 agent transitions in 8 mini-batches, 10 epochs,
the default MLP, torch on one thread in the training process) for ``--timesteps`` agent
transitions, and reports ``model.num_timesteps / wall time``. The env copies run in the
training process (``workers = 1``: :class:`~baselines.rl.sb3_env.TeamVecEnv`) or in worker
processes (:class:`~baselines.rl.subproc.SubprocTeamVecEnv`). MPE2's ``simple_spread``
(``N`` agents, continuous actions, 25-step episodes) goes through the same adapters, so the
comparison is of the envs and the process layout, not of the glue. Navigation-v0 runs twice:
as ``TeamVecEnv`` steps it by default (its copies as one
:class:`~teamgym.envs.navigation.batch.NavigationBatch`) and one copy at a time through the
PettingZoo API (``batched=False``, "per copy"). Cases are interleaved
over ``--rounds`` rounds and the best round of each is reported (the least disturbed by
other load); quote the ratios, measured in one run.

    python benchmarks/bench_training_throughput.py [--timesteps 20000] [--rounds 2] [--n-envs 4]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable

import torch
from stable_baselines3 import PPO

import teamgym
from baselines.rl.sb3_env import TeamVecEnv
from baselines.rl.subproc import SubprocTeamVecEnv
from baselines.rl.train import default_hyperparameters


def navigation(n_robots: int) -> Callable[[], object]:
    return lambda: teamgym.make("Navigation-v0", n_robots=n_robots)


def simple_spread(n_agents: int) -> Callable[[], object] | None:
    try:
        from mpe2 import simple_spread_v3
    except ImportError:
        return None
    return lambda: simple_spread_v3.parallel_env(N=n_agents, continuous_actions=True)


def throughput(
    env_fn: Callable[[], object], n_envs: int, workers: int, timesteps: int, batched: bool | None = None
) -> tuple[float, float]:
    """(agent-steps/s, padding share) of PPO trained for ``timesteps`` agent transitions."""
    if workers == 1:
        venv = TeamVecEnv(env_fn, n_envs=n_envs, batched=batched)
    else:
        venv = SubprocTeamVecEnv(env_fn, n_envs, n_workers=workers, batched=batched)
    model = PPO("MlpPolicy", venv, seed=0, device="cpu", verbose=0, **default_hyperparameters("ppo", venv.num_envs))
    start = time.perf_counter()
    model.learn(timesteps)
    rate = model.num_timesteps / (time.perf_counter() - start)
    padding = venv.padding_share
    venv.close()
    return rate, padding


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=20_000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--n-envs", type=int, default=4)
    parser.add_argument("--agents", type=int, default=3)
    parser.add_argument("--json", type=str, default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    cases = {
        "teamgym Navigation-v0": (navigation(args.agents), None),
        "MPE2 simple_spread": (simple_spread(args.agents), None),
        "Navigation-v0 per copy": (navigation(args.agents), False),
    }
    best: dict[tuple[str, int], tuple[float, float]] = {}
    for _ in range(args.rounds):
        for name, (env_fn, batched) in cases.items():
            if env_fn is None:
                continue
            for workers in (1, 2):
                rate, padding = throughput(env_fn, args.n_envs, workers, args.timesteps, batched)
                if rate > best.get((name, workers), (0.0, 0.0))[0]:
                    best[(name, workers)] = (rate, padding)
    machine = f"{platform.machine()}, {os.cpu_count()} cores"
    setting = f"{args.agents} agents, {args.n_envs} env copies, best of {args.rounds} x {args.timesteps}"
    print(f"PPO agent-steps/s, {setting} ({machine})")
    print(f"{'env':<24} {'1 process':>10} {'2 workers':>10} {'2w/1p':>7}")
    rows = []
    for name in cases:
        if (name, 1) not in best:
            print(f"{name:<24} {'n/a':>10}")
            continue
        one, two = best[(name, 1)][0], best[(name, 2)][0]
        print(f"{name:<24} {one:10.0f} {two:10.0f} {two / one:6.2f}x")
        rows.append({"env": name, "one_process": one, "two_workers": two, "padding_share": best[(name, 1)][1]})
    if len(rows) == 3:
        for label, key in (("1 process", "one_process"), ("2 workers", "two_workers")):
            print(f"teamgym / MPE2, {label}: {rows[0][key] / rows[1][key]:.2f}x")
            print(f"teamgym batched / per copy, {label}: {rows[0][key] / rows[2][key]:.2f}x")
    print(f"padding share (teamgym, 1 process): {rows[0]['padding_share']:.1%}")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(rows, handle, indent=2)


if __name__ == "__main__":
    main()
