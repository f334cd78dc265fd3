"""Where a batch's step goes: time per copy-step of each phase of ``teamgym.make_batch(env_id, K)``.

Wraps the batch's phases (:class:`teamgym.envs.step_loop.CopyPhases`: ``control``,
``physics``, ``after_physics``, ``end``, ``observe``) with timers; what is left of
``TeamBatch.step`` (action checks, masks, copying observations, auto-reset) is "batch".
``--inner MODULE:NAME`` (or ``MODULE:Class.method``) also times a function called inside a phase
(shown indented, part of its phase), e.g. ``teamgym.envs.box_pushing.phases:read_sensors``. Actions as in
``bench_batch_every_env.py`` (uniform in a Box, the first admissible discrete action).
Process CPU time; best of ``--rounds``. ``--lone`` also steps one lone env (``step(dict)``, the
same action rule, ``--steps`` steps from a reset, resets when its episode ends) in each round and
prints both rates in agent-steps/s and their ratio (issue 24's aim: 64 copies ≥ 3× one lone env).

``--set KEY=VALUE`` (repeatable) configures the batch and the lone env alike (e.g.
``--set action_type=operator``: macro actions whose stages end copy by copy).

    python benchmarks/bench_batch_phases.py --env BoxPushing-v0 --copies 64 [--steps 64] [--rounds 3] [--inner ...] [--lone]
        [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import importlib
import time

import numpy as np
from gymnasium import spaces

import teamgym

PHASES = ("control", "physics", "after_physics", "end", "observe")


def _actions(batch, rng: np.random.Generator) -> np.ndarray:
    shape = (batch.n_copies, batch.n_robots)
    space = batch.action_space
    if isinstance(space, spaces.Discrete):
        masks = batch.action_masks()
        return np.zeros(shape, dtype=np.int64) if masks is None else np.argmax(masks, axis=-1)
    return rng.uniform(space.low, space.high, size=(*shape, *space.shape)).astype(space.dtype)


def lone_rate(env_id: str, steps: int, config: dict | None = None) -> float:
    """Agent-steps/s of one lone env through ``step(dict)``, with the actions of :func:`_actions` (process CPU time)."""
    agent_steps, seconds = lone_run(env_id, steps, config)
    return agent_steps / seconds


def lone_run(env_id: str, steps: int, config: dict | None = None) -> tuple[int, float]:
    """Agent-steps and process CPU seconds of ``steps`` steps of one lone env from its reset (make and reset untimed)."""
    env = teamgym.make(env_id, **(config or {}))
    env.reset(seed=0)
    space = env.action_space(env.possible_agents[0])
    rng = np.random.default_rng(0)
    agent_steps, start = 0, time.process_time()
    for _ in range(steps):
        if not env.agents:
            env.reset()
        if isinstance(space, spaces.Discrete):
            masks = env.action_masks()
            actions = {a: int(np.argmax(masks[a])) if masks.get(a) is not None else 0 for a in env.agents}
        else:
            actions = {a: rng.uniform(space.low, space.high).astype(space.dtype) for a in env.agents}
        agent_steps += len(actions)
        env.step(actions)
    return agent_steps, time.process_time() - start


def profile(
    env_id: str, copies: int, steps: int, inner: list[str], config: dict | None = None
) -> tuple[float, dict[str, float], float]:
    """Seconds per copy-step in all and per phase (``inner`` functions too), and the batch's agent-steps/s."""
    clock = time.process_time
    spent: dict[str, float] = {}

    def timed(name, function):
        def run(*args, **kwargs):
            start = clock()
            try:
                return function(*args, **kwargs)
            finally:
                spent[name] = spent.get(name, 0.0) + clock() - start

        return run

    restore = []
    for target in inner:  # MODULE:NAME or MODULE:Class.method
        module_name, path = target.split(":")
        owner = importlib.import_module(module_name)
        *classes, name = path.split(".")
        for part in classes:
            owner = getattr(owner, part)
        original = owner.__dict__[name] if isinstance(owner, type) else getattr(owner, name)
        restore.append((owner, name, original))
        function = original.__func__ if isinstance(original, staticmethod) else original
        wrapped = timed(f"  {path}", function)
        setattr(owner, name, staticmethod(wrapped) if isinstance(original, staticmethod) else wrapped)
    try:
        batch = teamgym.make_batch(env_id, copies, auto_reset=True, **(config or {}))
        batch.reset(seed=0)
        phases = batch._phases
        for name in PHASES:
            setattr(phases, name, timed(name, getattr(phases, name)))
        rng = np.random.default_rng(0)
        for _ in range(3):
            batch.step(_actions(batch, rng))
        spent.clear()
        copy_steps, agent_steps, start = 0, 0, clock()
        for _ in range(steps):
            copy_steps += int(batch.active.any(axis=1).sum())
            agent_steps += int(batch.active.sum())
            batch.step(_actions(batch, rng))
        total = clock() - start
    finally:
        for owner, name, function in restore:
            setattr(owner, name, function)
    per = {name: value / copy_steps for name, value in spent.items()}
    per["batch"] = (total - sum(v for k, v in spent.items() if not k.startswith(" "))) / copy_steps
    return total / copy_steps, per, agent_steps / total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="BoxPushing-v0")
    parser.add_argument("--copies", type=int, default=64)
    parser.add_argument("--steps", type=int, default=64)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--inner", nargs="*", default=[], help="MODULE:NAME functions to time inside the phases")
    parser.add_argument("--lone", action="store_true", help="also time one lone env and print agent-steps/s of both")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="env config (repeatable)")
    args = parser.parse_args()
    config = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            parser.error(f"--set expects KEY=VALUE, got {item!r}")
        config[key.strip()] = value.strip()
    try:
        teamgym.make(args.env, **config)
    except (ValueError, TypeError, KeyError) as error:
        parser.error(str(error).splitlines()[0])
    if args.env not in teamgym.envs() or min(args.copies, args.steps, args.rounds) < 1:
        parser.error(f"unknown env id {args.env!r}" if args.env not in teamgym.envs() else "--copies, --steps, --rounds >= 1")
    if any(target.count(":") != 1 for target in args.inner):
        parser.error("--inner takes MODULE:NAME")
    rounds, lone = [], 0.0
    for _ in range(args.rounds):  # a lone env's round beside each batch round, on the same machine load
        rounds.append(profile(args.env, args.copies, args.steps, args.inner, config))
        if args.lone:
            lone = max(lone, lone_rate(args.env, args.steps, config))
    total, per, rate = min(rounds, key=lambda r: r[0])
    print(f"{args.env} K={args.copies}: {1e6 * total:.1f} us per copy-step (best of {args.rounds} rounds)")
    for name, value in per.items():
        print(f"  {name:24s} {1e6 * value:7.1f} us  {100 * value / total:5.1f} %")
    if args.lone:
        print(f"agent-steps/s: batch of {args.copies} {rate:.0f}, lone env {lone:.0f}, batch/lone {rate / lone:.2f}x")


if __name__ == "__main__":
    main()
