"""A Foraging batch's numpy passes over copies (``teamgym.envs.foraging.group``) step as the lone env, bit for bit.

A batch of copies whose robots are all in their episodes runs the go-to controller, odometry,
presence, goals, rewards, sensing and observations once over every copy; a lone env runs its
scalar per-robot code. Here batches of four copies and four lone envs with the same seeds take
the same actions for long episodes in settings chosen to exercise every branch: robots driven
to the targets (consumption, surrounding, homing, stops), crowds on a small field (occlusion,
avoidance pushes), dense landmarks (re-localisation), ``persist``, a graded radio, no vision
noise, velocity actions and learned messages. Every step compares observations, rewards, ends,
infos and each copy's whole ``ForagingArrays`` row; counters check that the batch took the
group path and that the rare branches happened.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import teamgym
from teamgym.envs.foraging import group as group_module
from teamgym.envs.foraging import phases as phases_module

CONFIGS = {
    "consume": {"n_robots": 2, "n_targets": 3, "consume_time": 0.5, "time_limit": 30.0},
    "crowd": {
        "n_robots": 6,
        "n_targets": 2,
        "field_size": (2.0, 1.6),
        "landmark_spacing": 0.2,
        "consume_time": 1.0,
        "time_limit": 20.0,
    },
    "persist-radio": {
        "n_robots": 3,
        "consumed_targets": "persist",
        "consume_time": 0.4,
        "comm_throughput": 0.6,
        "packet_rate": 2.5,
        "time_limit": 20.0,
    },
    "surround": {"n_robots": 4, "task": "surround", "robots_per_target": 2, "field_size": (2.0, 1.6), "time_limit": 20.0},
    "exact-vision": {"n_robots": 3, "vision_noise": 0.0, "rotational_certainty": 1.0, "time_limit": 15.0},
    "velocity": {"n_robots": 3, "action_type": "velocity", "field_size": (2.0, 1.6), "time_limit": 15.0},
    "messages": {"n_robots": 3, "comm_dim": 2, "obs_format": "dict", "field_size": (2.0, 1.6), "time_limit": 15.0},
    "world-model": {"n_robots": 2, "observe_world_model": True, "observe_novelty": True, "time_limit": 10.0},
}


def _cell_of(env, xy) -> int:
    gx, gy = env.grid.cell_of(np.asarray(xy))
    return int(gy * env.grid.nx + gx)


def _policy(batch, rng: np.random.Generator):
    """Most robots head for the cell of their copy's nearest live target; a few pick a random admissible cell."""
    space = batch.action_space
    shape = (batch.n_copies, batch.n_robots)
    if not hasattr(space, "n") and not hasattr(space, "spaces"):
        return rng.uniform(space.low, space.high, size=(*shape, *space.shape)).astype(space.dtype)
    masks = batch.action_masks()
    cells = np.zeros(shape, dtype=np.int64)
    for k, env in enumerate(batch.copies):
        live = np.flatnonzero(env.target_live) if env.world is not None else []
        for i in range(batch.n_robots):
            if len(live) and rng.random() < 0.8:
                gaps = np.hypot(*(env.targets[live] - env._pose[i, :2]).T)
                cells[k, i] = _cell_of(env, env.targets[live[int(np.argmin(gaps))]])
            else:
                cells[k, i] = rng.choice(np.flatnonzero(masks[k, i]))
    if hasattr(space, "spaces"):  # motion plus a learned message
        message = rng.uniform(-1, 1, size=(*shape, *space.spaces["message"].shape)).astype(np.float32)
        return {"motion": cells, "message": message}
    return cells


def _lone_action(actions, k: int, i: int):
    if isinstance(actions, dict):
        return {key: value[k, i] for key, value in actions.items()}
    value = actions[k, i]
    return int(value) if np.ndim(value) == 0 else value


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[key], b[key]) for key in a)
    return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f")


def compare(name: str, steps: int = 400) -> dict[str, int]:
    """Step a batch of four copies and four lone envs with ``CONFIGS[name]``, asserting every step is the same;
    returns how often the group path ran and its rare branches happened."""
    config = CONFIGS[name]
    calls = {"group": 0, "fixes": 0, "finished": 0, "occlusion checks": 0, "episodes": 0}
    perceive, occluded = group_module.perceive_copies, group_module._occluded

    def counted_perceive(*args, **kwargs):
        calls["group"] += 1
        before = args[4].copy()
        sensed = perceive(*args, **kwargs)
        calls["fixes"] += int(np.count_nonzero(sensed.certainty > before))
        return sensed

    def counted_occluded(*args, **kwargs):
        calls["occlusion checks"] += 1
        return occluded(*args, **kwargs)

    smallest = phases_module.ForagingPhases.min_group
    phases_module.perceive_copies, group_module._occluded = counted_perceive, counted_occluded
    phases_module.ForagingPhases.min_group = 2  # four copies: below the default, so lowered to take the group path
    try:
        _compare(config, name, steps, calls)
    finally:
        phases_module.perceive_copies, group_module._occluded = perceive, occluded
        phases_module.ForagingPhases.min_group = smallest
    return calls


def _compare(config: dict, name: str, steps: int, calls: dict[str, int]) -> None:
    copies = 4
    batch = teamgym.make_batch("Foraging-v0", copies, **config)
    lones = [teamgym.make("Foraging-v0", **config) for _ in range(copies)]
    batch.reset(seed=70)
    for k, env in enumerate(lones):
        env.reset(seed=70 + k)
    rng = np.random.default_rng(3)
    for step in range(steps):
        actions = _policy(batch, rng)
        observations, rewards, terminated, truncated = batch.step(actions)
        for k, env in enumerate(lones):
            if not env.agents:
                continue
            obs, rew, term, trunc, infos = env.step({a: _lone_action(actions, k, env._row[a]) for a in env.agents})
            batch_infos = batch.infos(k)
            for agent in obs:
                i = env._row[agent]
                if isinstance(obs[agent], dict):
                    batch_obs = {key: value[k, i] for key, value in observations.items()}
                else:
                    batch_obs = observations[k, i]
                assert _same(batch_obs, obs[agent]), (name, step, k, agent)
                assert (rew[agent], term[agent], trunc[agent]) == (rewards[k, i], terminated[k, i], truncated[k, i]), (step, k)
                assert _same(batch_infos[agent], infos[agent]), (step, k, agent)
            assert _same(batch.copies[k]._arrays.row(k), env._arrays.row(0)), (name, step, k)
        calls["finished"] = max(calls["finished"], int(sum(np.count_nonzero(~env.target_live) for env in lones)))
        for k, env in enumerate(lones):
            if not env.agents:  # a new episode in this copy and its lone env, with the same seed
                calls["episodes"] += 1
                batch.reset_copy(k, seed=1000 + calls["episodes"])
                env.reset(seed=1000 + calls["episodes"])


@pytest.mark.parametrize("name", list(CONFIGS))
def test_a_batch_group_steps_every_copy_as_its_lone_env(name):
    calls = compare(name)
    assert calls["group"] > 0, "the batch never took the group path"
    if name != "velocity":
        assert calls["finished"] > 0 or calls["episodes"] > 0, "no target was ever finished"
    if name == "crowd":
        assert calls["fixes"] > 0 and calls["occlusion checks"] > 0, calls


def test_the_group_path_matches_with_numpy_avx512_kernels_on():
    """The suite runs numpy without its AVX-512 kernels (``tests/conftest.py``), under which numpy's ``arctan2`` and
    ``power`` equal libm's; users' runs may have them on. In a process with them on (where the CPU has them), the
    group path still matches the lone env: it takes transcendentals from ``math``, as the lone env does."""
    environment = {key: value for key, value in os.environ.items() if key != "NPY_DISABLE_CPU_FEATURES"}
    script = f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); import {Path(__file__).stem} as t; "
    script += "print(t.compare('crowd', 150)); print(t.compare('consume', 150))"
    result = subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr[-2000:]


def test_a_lone_env_keeps_its_scalar_path(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("a lone env took the group path")

    monkeypatch.setattr(phases_module, "perceive_copies", refuse)
    env = teamgym.make("Foraging-v0")
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: 0 for a in env.agents})
