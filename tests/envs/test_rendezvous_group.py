"""A Rendezvous batch's passes over a group of copies (``teamgym.envs.rendezvous.group``) step as the lone env.

A batch drives every robot of every copy in its stage with one pass of the way-following
arithmetic, finds arrivals and time-outs in one pass and decides which stages go on from the
arrays; a lone env does each robot in scalar ``math``. Batches of five copies and five lone
envs with the same seeds and moves run long episodes (meetings, head-on robots that stop and
give up a way, scheduled, random and arrival blockings, three robots, ``stage_end="all"``);
every step compares observations, rewards, ends, infos and each copy's ``RendezvousArrays``
row. Counters check that the group path ran and that give-ups happened. One run repeats in a
process with numpy's AVX-512 kernels on (the suite turns them off), where only ``math`` matches libm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from teamgym.control.way_following import WayFollower
from teamgym.envs.rendezvous import group as group_module
from teamgym.envs.rendezvous import phases as phases_module
from teamgym.envs.rendezvous.actions import nearest_ahead
from teamgym.sim.libm import remainder_tau
from tests.batch_lockstep import lockstep, with_avx512_kernels

CONFIGS = {
    "paper-map": {"max_cycles": 3000},
    "blockings": {
        "map": "square4",
        "n_robots": 3,
        "blockings": (("A", "B", 3.0),),
        "arrival_blockings": (("B", "C", "A", 1),),
        "block_rate": 0.02,
        "max_cycles": 3000,
    },
    "all-arrive": {"stage_end": "all", "max_cycles": 3000},
}


def compare(name: str, steps: int = 150) -> dict[str, int]:
    """Step five copies and five lone envs with ``CONFIGS[name]`` and the same random moves, asserting every step;
    returns how often the group paths ran and how many moves were given up."""
    config = CONFIGS[name]
    calls = {"group commands": 0, "give-ups": 0, "episodes": 0}
    commands = phases_module.way_commands

    def counted(*args, **kwargs):
        calls["group commands"] += 1
        return commands(*args, **kwargs)

    smallest = phases_module.RendezvousPhases.min_group
    phases_module.way_commands = counted
    phases_module.RendezvousPhases.min_group = 2  # five copies: below the default, so lowered to take the group path
    try:
        _compare(config, name, steps, calls)
    finally:
        phases_module.way_commands = commands
        phases_module.RendezvousPhases.min_group = smallest
    return calls


def _compare(config: dict, name: str, steps: int, calls: dict[str, int]) -> None:
    rng = np.random.default_rng(5)

    def moves(batch) -> np.ndarray:
        return np.array([[rng.choice(np.flatnonzero(m)) for m in rows] for rows in batch.action_masks()])

    def gave_up(env) -> None:
        calls["give-ups"] += int(env._arrays.failed_moves[0].sum())

    def by_way(row: dict) -> dict:  # the blocker entities are each env's own objects: compare which ways hold one
        return {**row, "blockers": list(row["blockers"])}

    calls["episodes"] = lockstep("Rendezvous-v0", config, 5, 11, steps, moves, gave_up, by_way)


@pytest.mark.parametrize(("name", "steps"), [("paper-map", 150), ("blockings", 50), ("all-arrive", 150)])
def test_a_batch_group_steps_every_copy_as_its_lone_env(name, steps):
    calls = compare(name, steps)
    assert calls["group commands"] > 0, "the batch never drove a group in one pass"
    assert calls["episodes"] > 0
    if name == "blockings":
        assert calls["give-ups"] > 0, "no robot gave up a way"


def test_the_group_path_matches_with_numpy_avx512_kernels_on():
    """As ``tests/envs/test_foraging_group.py``: a process with numpy's AVX-512 kernels on (where the CPU has them)."""
    result = with_avx512_kernels(__file__, "t.compare('paper-map', 60); t.compare('blockings', 30)")
    assert result.returncode == 0, result.stderr[-2000:]


def test_remainder_tau_is_math_remainder_bit_for_bit():
    rng = np.random.default_rng(0)
    ties = np.arange(-41, 42) * math.pi  # odd multiples of π lie half-way between multiples of τ
    values = np.concatenate([rng.normal(size=20000) * 10, rng.normal(size=2000) * 1e7, ties, [0.0, -0.0, math.tau, 1e-300]])
    expected = np.array([math.remainder(v, math.tau) for v in values])
    assert np.array_equal(remainder_tau(values).view(np.int64), expected.view(np.int64))


def test_way_commands_are_the_followers_commands_robot_by_robot():
    """Random poses near and far from their ways' ends (so arrivals, braking and stops all occur), three robots."""
    rng = np.random.default_rng(1)
    followers = [WayFollower(speed=0.1), WayFollower(speed=0.07, stop_distance=0.12), WayFollower(speed=0.13)]
    rows = group_module.FollowerRows(followers, {}, 12)
    places = rng.uniform(0.0, 1.0, (12, 2))
    g = 400
    origin, target = rng.integers(0, 12, (g, 3)), rng.integers(-1, 12, (g, 3))
    ends = places[np.maximum(target, 0)]
    poses = np.concatenate([ends + rng.normal(scale=0.03, size=(g, 3, 2)), rng.uniform(-math.pi, math.pi, (g, 3, 1))], axis=2)
    poses[::3, 1, :2] = poses[::3, 0, :2] + 0.05  # teammates close ahead or behind
    commands = group_module.way_commands(rows, poses, origin, target, places)
    for k in range(g):
        pose_rows = [tuple(row) for row in poses[k].tolist()]
        for i in range(3):
            if target[k, i] < 0:
                expected = (0.0, 0.0)
            else:
                start, end = tuple(places[origin[k, i]].tolist()), tuple(places[target[k, i]].tolist())
                expected = followers[i].command(pose_rows[i], start, end, nearest_ahead(i, pose_rows))
            assert commands[k, i].tolist() == list(expected), (k, i)
