"""Foraging-v0 lone step: this checkout against another (``--baseline``), in one run, CPU clock.

Two long-lived worker processes, one per checkout (``PYTHONPATH`` set to it), take turns:
every round each worker steps ``--steps`` control steps of the default config with random
``goto_cell`` actions and then ``--dmaps-steps`` steps driven by the ``dmaps`` baseline, and
reports the CPU time (``time.process_time``) spent inside ``env.step`` only. The rounds
alternate which worker goes first; the run reports the ratio of the medians of agent-steps/s
(this checkout / baseline) and the median of the per-round ratios.

Before timing, both workers roll out every config of :data:`CHECK_CONFIGS` (seeds
``--check-seeds``, up to 300 steps, random admissible actions, one deepcopy mid-episode
compared with the original) and a ``dmaps`` episode, and hash observations, rewards,
flags, numeric infos and ``env.state()``; the run fails unless the digests agree (a config
that one checkout refuses, such as ``fixed_agents`` before it existed, is skipped and named).

Both workers run with numpy's AVX-512 kernels off, as the tests do (``tests/conftest.py``).

    python benchmarks/bench_foraging_step.py --baseline /work/main [--rounds 7] [--steps 3000]
"""

from __future__ import annotations

import argparse
import copy
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

#: The digest of a check config that a checkout refuses (a key it does not know): left out of the comparison.
UNSUPPORTED = "unsupported"
#: Configs whose rollouts must agree bit for bit between the two checkouts.
CHECK_CONFIGS: tuple[dict, ...] = (
    {},
    {"obs_format": "dict"},
    {"n_robots": 4, "n_targets": 5},
    {"n_robots": 5, "n_targets": 2, "task": "surround", "robots_per_target": 3},
    {"n_robots": 3, "comm_throughput": 0.6, "comm_latency": 2, "comm_range": 1.2},
    {"n_robots": 3, "comm_byte_budget": 20},
    {"vision_noise": 0.0, "odometry_rotation_noise": 0.0, "odometry_distance_noise": 0.0},
    {"action_type": "velocity", "n_robots": 3},
    {"observe_world_model": True, "n_robots": 3},
    {"comm_dim": 2, "n_robots": 3},
    {"fixed_agents": True, "n_robots": 3},
    {"n_robots": 1, "n_targets": 1},
    {"field_size": (3.1, 2.5), "cell_size": 0.3, "n_robots": 3},
    {"consume_time": 1.0, "time_limit": 20.0, "n_robots": 2},
)


def _feed(digest, value) -> None:
    import numpy as np

    if isinstance(value, dict):
        for key in sorted(value):
            digest.update(str(key).encode())
            _feed(digest, value[key])
    elif isinstance(value, (list, tuple)):
        for item in value:
            _feed(digest, item)
    elif isinstance(value, (str, bytes)) or value is None:
        digest.update(repr(value).encode())
    else:
        array = np.ascontiguousarray(np.asarray(value, dtype=np.float64))
        digest.update(f"{array.shape}".encode())
        digest.update(array.tobytes())


def _random_actions(env, infos, rng) -> dict:
    import numpy as np

    actions = {}
    for agent in env.agents:
        space = env.action_space(agent)
        mask = infos.get(agent, {}).get("action_mask")
        if hasattr(space, "spaces"):
            actions[agent] = {k: _sample(sub, None, rng) for k, sub in space.spaces.items()}
        else:
            actions[agent] = _sample(space, None if mask is None else np.asarray(mask), rng)
    return actions


def _sample(space, mask, rng):
    import numpy as np

    if mask is not None and mask.ndim == 1 and len(mask) == getattr(space, "n", -1):
        return int(rng.choice(np.flatnonzero(mask)))
    if hasattr(space, "n"):
        return int(rng.integers(space.n))
    return rng.uniform(space.low, space.high).astype(space.dtype)


def check_digests(seeds: int) -> dict[str, str]:
    """Digest of every check rollout (config label -> sha256)."""
    import numpy as np

    import teamgym
    from baselines.episode import run_episode
    from baselines.registry import make_policy
    from teamgym.envs.config import ConfigError

    out = {}
    for config in CHECK_CONFIGS:
        digest = hashlib.sha256()
        try:
            env = teamgym.make("Foraging-v0", **config)
        except ConfigError:  # a key an older checkout does not know (e.g. fixed_agents before it existed)
            out[json.dumps(config, sort_keys=True)] = UNSUPPORTED
            continue
        for seed in range(seeds):
            rng = np.random.default_rng(seed)
            obs, infos = env.reset(seed=seed)
            _feed(digest, [_without_mask(obs), _known(infos)])
            twin = None
            for step in range(300):
                if not env.agents:
                    break
                if step == 150:
                    twin = copy.deepcopy(env)
                actions = _random_actions(env, infos, rng)
                result = env.step(actions)
                if twin is not None:
                    same = twin.step(actions)
                    _feed(digest, {"twin_equal": float(_digest_of(same) == _digest_of(result))})
                obs, infos = result[0], result[4]
                _feed(digest, [_without_mask(result[0]), *result[1:4], _known(infos)])
                _feed(digest, env.state())
        out[json.dumps(config, sort_keys=True)] = digest.hexdigest()
    for config in ({}, {"n_robots": 3, "comm_throughput": 0.7}):
        env = teamgym.make("Foraging-v0", **config)
        results = [run_episode(env, make_policy("dmaps", env), seed=s, record_trajectories=False) for s in range(2)]
        out[f"dmaps {json.dumps(config, sort_keys=True)}"] = hashlib.sha256(repr(results).encode()).hexdigest()
    return out


def _known(infos: dict) -> dict:
    """``infos`` without the entries that hold the fixed schema's "not known yet" sentinel (-1.0): a checkout from
    before that schema leaves those keys out until they are known (e.g. ``TL`` before a target is seen)."""
    return {agent: {k: v for k, v in info.items() if not (isinstance(v, float) and v == -1.0)} for agent, info in infos.items()}


def _without_mask(observations: dict) -> dict:
    """Dict observations without their ``action_mask`` field (added after 7f006cd; ``infos`` still hold the masks)."""
    return {a: {k: v for k, v in o.items() if k != "action_mask"} if isinstance(o, dict) else o for a, o in observations.items()}


def _digest_of(result) -> str:
    digest = hashlib.sha256()
    _feed(digest, list(result))
    return digest.hexdigest()


def time_round(steps: int, dmaps_steps: int, seed: int) -> dict[str, float]:
    """CPU seconds inside ``env.step`` for ``steps`` random and ``dmaps_steps`` DMAPS steps (default config)."""
    import numpy as np

    import teamgym
    from baselines.registry import make_policy

    env = teamgym.make("Foraging-v0")
    figures = {}
    for mode, budget in (("random", steps), ("dmaps", dmaps_steps)):
        spent, agent_steps, done, episode = 0.0, 0, 0, 0
        while done < budget:
            obs, infos = env.reset(seed=seed + episode)
            rng = np.random.default_rng(seed + episode)
            policy = make_policy("dmaps", env) if mode == "dmaps" else None
            if policy is not None:
                policy.reset(seed + episode)
            episode += 1
            while env.agents and done < budget:
                if policy is None:
                    actions = {a: int(rng.integers(env.action_space(a).n)) for a in env.agents}
                else:
                    actions = policy.act(obs, infos)
                n = len(env.agents)
                start = time.process_time()
                obs, _, _, _, infos = env.step(actions)
                spent += time.process_time() - start
                agent_steps += n
                done += 1
        figures[mode] = agent_steps / spent
    return figures


def worker() -> None:
    """Serve requests (one JSON line each) from the parent on stdin; answer one JSON line each."""
    for line in sys.stdin:
        request = json.loads(line)
        if request["do"] == "check":
            answer = check_digests(request["seeds"])
        else:
            answer = time_round(request["steps"], request["dmaps_steps"], request["seed"])
        print(json.dumps(answer), flush=True)


def _numpy_env() -> dict[str, str]:
    env = dict(os.environ)
    if "NPY_DISABLE_CPU_FEATURES" not in env:
        probe = (
            "from numpy._core._multiarray_umath import __cpu_dispatch__ as d, __cpu_features__ as f;"
            "print(' '.join(x for x in d if f.get(x) and ('AVX512' in x or x == 'X86_V4')))"
        )
        found = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.strip()
        if found:
            env["NPY_DISABLE_CPU_FEATURES"] = found
    return env


class Worker:
    """A worker process on one checkout."""

    def __init__(self, tree: Path) -> None:
        env = {**_numpy_env(), "PYTHONPATH": str(tree)}
        self.tree = tree
        self.process = subprocess.Popen(
            [sys.executable, __file__, "--worker"], cwd=tree, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )

    def ask(self, **request) -> dict:
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"worker on {self.tree} died")
        return json.loads(line)

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--baseline", type=Path, required=False, help="the other checkout (e.g. /work/main)")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--steps", type=int, default=3000, help="random-action control steps per round")
    parser.add_argument("--dmaps-steps", type=int, default=1000, help="DMAPS-driven control steps per round")
    parser.add_argument("--check-seeds", type=int, default=3, help="seeds per check config (0: skip the check)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker()
        return
    if args.baseline is None:
        parser.error("--baseline is required")
    trees = {"this": Worker(HERE), "baseline": Worker(args.baseline.resolve())}
    print(f"# Foraging-v0 lone step: {HERE} vs {args.baseline.resolve()}; CPU clock; {os.cpu_count()} CPUs")
    print(f"# NPY_DISABLE_CPU_FEATURES={_numpy_env().get('NPY_DISABLE_CPU_FEATURES', '')!r}")
    failed = False
    if args.check_seeds:
        digests = {name: w.ask(do="check", seeds=args.check_seeds) for name, w in trees.items()}
        skipped = [k for k in digests["this"] if UNSUPPORTED in (digests["this"][k], digests["baseline"].get(k))]
        differ = [k for k in digests["this"] if k not in skipped and digests["this"][k] != digests["baseline"].get(k)]
        print(
            f"check: {len(digests['this']) - len(skipped)} rollout digests compared, {len(differ)} differ"
            + "".join(f"\n  differs: {k}" for k in differ)
            + "".join(f"\n  skipped (a checkout refuses the config): {k}" for k in skipped)
        )
        failed = bool(differ)
    figures: dict[str, dict[str, list[float]]] = {name: {"random": [], "dmaps": []} for name in trees}
    for r in range(args.rounds):
        order = list(trees) if r % 2 == 0 else list(trees)[::-1]
        for name in order:
            result = trees[name].ask(do="time", steps=args.steps, dmaps_steps=args.dmaps_steps, seed=100 * r)
            for mode, value in result.items():
                figures[name][mode].append(value)
        print(
            f"round {r}: "
            + ", ".join(f"{name} {figures[name]['random'][-1]:.0f}/{figures[name]['dmaps'][-1]:.0f}" for name in trees),
            flush=True,
        )
    for w in trees.values():
        w.close()
    for mode in ("random", "dmaps") if args.rounds else ():
        this, base = (statistics.median(figures[name][mode]) for name in ("this", "baseline"))
        paired = statistics.median(a / b for a, b in zip(figures["this"][mode], figures["baseline"][mode]))
        print(
            f"{mode:6s} actions: agent-steps/s this {this:.0f}, baseline {base:.0f} (medians of {args.rounds} rounds): "
            f"ratio {this / base:.2f}x; median of the per-round ratios {paired:.2f}x"
        )
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
