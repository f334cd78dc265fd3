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

import numpy as np
import pytest

import teamgym
from teamgym.envs.foraging import group as group_module
from teamgym.envs.foraging import phases as phases_module
from tests.batch_lockstep import lockstep, with_avx512_kernels

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
    "own-world-model": {"n_robots": 3, "observe_world_model": True, "world_model_sources": "own", "time_limit": 10.0},
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
    rng = np.random.default_rng(3)

    def finished(env) -> None:
        calls["finished"] = max(calls["finished"], int(np.count_nonzero(~env.target_live)))

    calls["episodes"] = lockstep("Foraging-v0", config, 4, 70, steps, lambda batch: _policy(batch, rng), finished)


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
    result = with_avx512_kernels(__file__, "t.compare('crowd', 150); t.compare('consume', 150)")
    assert result.returncode == 0, result.stderr[-2000:]


def test_a_lone_env_keeps_its_scalar_path(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("a lone env took the group path")

    monkeypatch.setattr(phases_module, "perceive_copies", refuse)
    env = teamgym.make("Foraging-v0")
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: 0 for a in env.agents})
