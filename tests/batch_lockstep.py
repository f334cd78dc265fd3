"""A batch of env copies and lone envs with the same seeds stepped in lockstep, every step compared (batch tests)."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import teamgym


def same(a: Any, b: Any) -> bool:
    """Equal values, dicts, lists and arrays (NaN equal to NaN), for comparing a batch's rows with a lone env's."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[key], b[key]) for key in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f")
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    return a == b


def lone_action(actions: Any, k: int, i: int) -> Any:
    """Robot row ``i`` of copy ``k`` of a batch's actions (arrays, or a dict of arrays), as a lone env takes it."""
    if isinstance(actions, dict):
        return {key: value[k, i] for key, value in actions.items()}
    value = actions[k, i]
    return int(value) if np.ndim(value) == 0 else value


def lockstep(
    env_id: str,
    config: dict,
    copies: int,
    seed: int,
    steps: int,
    choose: Callable[[Any], Any],
    episode_over: Callable[[Any], None] | None = None,
    state_row: Callable[[dict], dict] = lambda row: row,
) -> int:
    """Step ``copies`` copies of a batch and as many lone envs (seeds ``seed + k``) with the batch's actions
    ``choose(batch)`` for ``steps`` steps, asserting at every step that each copy's observations, rewards,
    ends, infos and episode-state row (``state_row`` of it) equal its lone env's. A copy whose episode ended
    starts again in both, with a new seed, after ``episode_over(lone env)``. Returns the episodes restarted."""
    batch = teamgym.make_batch(env_id, copies, **config)
    lones = [teamgym.make(env_id, **config) for _ in range(copies)]
    batch.reset(seed=seed)
    for k, env in enumerate(lones):
        env.reset(seed=seed + k)
    episodes = 0
    for step in range(steps):
        actions = choose(batch)
        observations, rewards, terminated, truncated = batch.step(actions)
        for k, env in enumerate(lones):
            if not env.agents:
                continue
            obs, rew, term, trunc, infos = env.step({a: lone_action(actions, k, env._row[a]) for a in env.agents})
            batch_infos = batch.infos(k)
            for agent in obs:
                i = env._row[agent]
                if isinstance(obs[agent], dict):
                    mine = {key: value[k, i] for key, value in observations.items()}
                else:
                    mine = observations[k, i]
                assert same(mine, obs[agent]), (env_id, step, k, agent)
                assert (rew[agent], term[agent], trunc[agent]) == (rewards[k, i], terminated[k, i], truncated[k, i]), (step, k)
                assert same(batch_infos[agent], infos[agent]), (step, k, agent)
            assert same(state_row(batch.copies[k]._arrays.row(k)), state_row(env._arrays.row(0))), (env_id, step, k)
        for k, env in enumerate(lones):
            if not env.agents:
                if episode_over is not None:
                    episode_over(env)
                episodes += 1
                batch.reset_copy(k, seed=seed + 1000 + episodes)
                env.reset(seed=seed + 1000 + episodes)
    return episodes


def with_avx512_kernels(test_file: str, calls: str) -> subprocess.CompletedProcess:
    """Run ``calls`` (Python on ``t``, the test module ``test_file``) in a process with numpy's AVX-512 kernels on
    (where the CPU has them): the suite turns them off (``tests/conftest.py``), users' runs may not."""
    environment = {key: value for key, value in os.environ.items() if key != "NPY_DISABLE_CPU_FEATURES"}
    here = Path(test_file)
    script = f"import sys; sys.path[:0] = [{str(here.parent)!r}, {str(here.parents[2])!r}]; import {here.stem} as t; {calls}"
    return subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True, check=False)
