"""Padding share of ``TeamVecEnv`` batches: the slot-steps in which a slot waits for a robot.

A trained agent (default: the shipped ``navigation-ppo``, deterministic) drives every slot of
a :class:`~baselines.rl.sb3_env.TeamVecEnv` for ``--steps`` VecEnv steps, with 1 and with
``--n-envs`` copies. With one copy a slot whose robot arrived waits until the whole team is
done, which is exactly what the old adapter did at any number of copies (its padding share);
with more copies free slots are refilled from other copies.

    python benchmarks/bench_padding_share.py [--agent navigation-ppo] [--steps 2000] [--n-envs 8]
"""

from __future__ import annotations

import argparse

import torch

import teamgym
from baselines.rl.sb3_env import TeamVecEnv
from baselines.rl.sb3_policy import algorithm_class, detect_algorithm, read_sidecar, resolve_model


def padding_share(agent: str, n_envs: int, steps: int, seed: int = 0) -> tuple[float, int]:
    """(padding share, robot episodes finished) over ``steps`` VecEnv steps."""
    path = resolve_model(agent)
    sidecar = read_sidecar(path) or {}
    model = algorithm_class(detect_algorithm(path) or "ppo").load(str(path), device="cpu")
    venv = TeamVecEnv(lambda: teamgym.make(sidecar["env"], **sidecar.get("config", {})), n_envs=n_envs)
    venv.seed(seed)
    obs = venv.reset()
    episodes = 0
    for _ in range(steps):
        actions, _ = model.predict(obs, deterministic=True)
        obs, _, dones, infos = venv.step(actions)
        episodes += sum(1 for done, info in zip(dones, infos) if done and "episode" in info)
    share = venv.padding_share
    venv.close()
    return share, episodes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", default="navigation-ppo")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--n-envs", type=int, default=8)
    args = parser.parse_args()
    torch.set_num_threads(1)
    print(f"padding share of TeamVecEnv slot-steps, agent {args.agent}, {args.steps} VecEnv steps")
    for n in sorted({1, args.n_envs}):
        share, episodes = padding_share(args.agent, n, args.steps)
        label = "1 copy (= the old adapter at any n_envs)" if n == 1 else f"{n} copies, slots refilled"
        print(f"  {label:<42} {100 * share:5.1f} %   ({episodes} robot episodes)")


if __name__ == "__main__":
    main()
