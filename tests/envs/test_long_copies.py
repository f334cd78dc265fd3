"""Copies mid-episode cost the same at any episode length and stay bit-identical (issue 23).

Every env re-bases every ``rebase_cycles`` control cycles (``TeamEnv``, "copying and
pickling"); these tests set it to ``M`` cycles, run episodes past several bases, copy
(deepcopy and pickle) right after a base, right before one and between two, and check that
original and copies go on bit for bit with the same actions; that a copy replays only the
steps since the last base; and that pickles do not grow with the episode beyond its trails.
"""

from __future__ import annotations

import copy
import pickle
import struct

import numpy as np
import pytest
from regression import _random_value, cases

import teamgym
from teamgym.envs.navigation.batch import NavigationBatch

M = 20
#: Macro action types whose steps last longer than ``M`` cycles get a longer interval, so that
#: some steps end between two bases.
MACRO_M = {("Rendezvous-v0", "next_place"): 150}
LONG = {"max_cycles": 1_000_000}
SEED = 1  # an episode that lasts with random actions in every env (Rendezvous seed 0 meets at once)


@pytest.fixture
def small_rebase(monkeypatch):
    """Every env re-bases every ``M`` control cycles (or ``MACRO_M``'s interval, given a case)."""

    def set_interval(env_id: str | None = None, action_type: str | None = None) -> int:
        m = MACRO_M.get((env_id, action_type), M)
        for name in teamgym.envs():
            monkeypatch.setattr(teamgym.env_class(name), "rebase_cycles", m)
        return m

    set_interval()
    return set_interval


def digest(value) -> bytes:
    """Bytes that differ whenever ``value`` differs in any bit (arrays: dtype, shape and data; floats: all 64 bits)."""
    if isinstance(value, dict):
        return b"{" + b"".join(repr(k).encode() + b":" + digest(value[k]) for k in sorted(value, key=repr)) + b"}"
    if isinstance(value, (list, tuple)):
        return b"[" + b",".join(digest(v) for v in value) + b"]"
    if isinstance(value, np.ndarray):
        return f"{value.dtype.str}{value.shape}".encode() + np.ascontiguousarray(value).tobytes()
    if isinstance(value, (float, np.floating)):
        return struct.pack("<d", float(value))
    return repr(value).encode()


def outcome(env, step_result) -> bytes:
    """Everything a step returns, and the env's state and cycle count after it."""
    state = env.state() if env.world is not None else None
    return digest([*step_result, state, env.cycles, env.agents])


def random_actions(env, infos, rng) -> dict:
    return {a: _random_value(env.action_space(a), infos.get(a, {}).get("action_mask"), rng, env) for a in env.agents}


def just_rebased(env) -> bool:
    return env._log[0][0] == "base" and len(env._log) == 1


def pickled(env):
    return pickle.loads(pickle.dumps(env))


def run(env, rng, infos, until, m: int = M, copying=lambda env: False) -> tuple[list, list, dict]:
    """Step ``env`` with random actions until ``until(env)``: each step's actions and outcome, and copies made on the way.

    While ``copying(env)``, copies (label -> (index of the next step, copy)) are made, one of
    each: just before the step that makes a base, right after a base (a pickle) and half way
    to the next base (a deepcopy).
    """
    actions_taken, outcomes, copies = [], [], {}
    last_step, halfway = 1, False
    while not until(env):
        assert env.agents, "the episode must outlast the test"
        actions = random_actions(env, infos, rng)
        wanted = copying(env) and "before a base" not in copies and env._cycles_since_base() + last_step >= m
        before = copy.deepcopy(env) if wanted else None
        cycles = env.cycles
        result = env.step(copy.deepcopy(actions))
        infos, last_step = result[-1], env.cycles - cycles
        actions_taken.append(actions)
        outcomes.append(outcome(env, result))
        if just_rebased(env):
            halfway = False
            if before is not None:
                copies["before a base"] = (len(outcomes) - 1, before)
            if copying(env) and "after a base" not in copies:
                copies["after a base"] = (len(outcomes), pickled(env))
        elif env._cycles_since_base() >= m // 2 and not halfway:
            halfway = True
            if copying(env) and "between bases" not in copies:
                copies["between bases"] = (len(outcomes), copy.deepcopy(env))
    return actions_taken, outcomes, copies


@pytest.mark.parametrize(("env_id", "action_type"), cases())
def test_copies_before_after_and_between_bases_continue_bit_for_bit(small_rebase, env_id, action_type):
    m = small_rebase(env_id, action_type)
    env = teamgym.make(env_id, action_type=action_type, **LONG)
    _, infos = env.reset(seed=SEED)
    bases = []

    def until(env):
        if just_rebased(env):
            bases.append(env.cycles)
        return len(bases) >= 5

    rng = np.random.default_rng(7)
    actions, outcomes, copies = run(env, rng, infos, until, m, copying=lambda env: 1 <= len(bases) <= 3)
    assert sorted(copies) == ["after a base", "before a base", "between bases"]
    longest = max(b - a for a, b in zip([0, *bases], bases)) - m + 1  # the longest step that ended at a base
    for label, (index, clone) in copies.items():
        assert clone._log[0][0] == "base", label  # rebuilt from the last snapshot, not from the reset
        assert clone._cycles_since_base() < m + longest, label
        for k in range(index, len(actions)):
            if k == (index + len(actions)) // 2:
                clone = pickled(clone)  # a copy of a copy, after it re-based on its own
            assert outcome(clone, clone.step(copy.deepcopy(actions[k]))) == outcomes[k], (label, k)


def non_trail_size(env) -> int:
    state = env.__getstate__()
    del state["trails"]
    return len(pickle.dumps(state))


@pytest.mark.parametrize(("env_id", "action_type"), cases())
def test_pickles_do_not_grow_with_the_episode_but_for_its_trails(small_rebase, env_id, action_type):
    """Right after every base the pickle holds a snapshot and an empty log; only the trails grow (16 bytes a point)."""
    m = small_rebase(env_id, action_type)
    env = teamgym.make(env_id, action_type=action_type, **LONG)
    _, infos = env.reset(seed=SEED)
    sizes, full, points = [], [], []

    def until(env):
        if just_rebased(env):
            sizes.append(non_trail_size(env))
            full.append(len(pickle.dumps(env)))
            points.append(sum(len(t) for t in (*env._trails.values(), *env._object_trails.values())))
        return len(sizes) >= 10

    run(env, np.random.default_rng(3), infos, until, m)
    assert max(sizes[1:]) <= 1.08 * sizes[1] and min(sizes[1:]) >= 0.92 * sizes[1], sizes
    assert full[-1] - full[1] <= 20 * (points[-1] - points[1]) + 2000, (full, points)


def test_a_batch_re_bases_where_single_envs_do_and_stays_exact(monkeypatch):
    """NavigationBatch copies stay bit-identical to single envs over a long episode, through many bases."""
    monkeypatch.setattr(teamgym.env_class("Navigation-v0"), "rebase_cycles", 15)
    config = {"n_robots": 3, "max_cycles": 100_000}
    batch = NavigationBatch(2, **config)
    observations = batch.reset(seed=11)
    envs = [teamgym.make("Navigation-v0", **config) for _ in range(2)]
    for e, env in enumerate(envs):
        env.reset(seed=11 + e)
    rng = np.random.default_rng(4)
    space, clones, bases = batch.action_space, [], 0
    for step in range(130):
        actions = rng.uniform(space.low, space.high, size=(2, 3, 2)).astype(np.float32)
        observations, rewards, terminated, truncated = batch.step(actions)
        for e, env in enumerate(envs):
            obs, rew, *_ = env.step({a: actions[e, i] for i, a in enumerate(env.possible_agents)})
            for i, agent in enumerate(env.possible_agents):
                assert np.array_equal(obs[agent], observations[e, i]) and rew[agent] == rewards[e, i], (step, e, agent)
            assert np.array_equal(env.state(), batch.copies[e].state())
            twin = batch.copies[e]
            assert just_rebased(env) == just_rebased(twin) and env._cycles_since_base() == twin._cycles_since_base()
        for clone in clones:
            again, again_rewards, *_ = clone.step(actions)
            assert np.array_equal(again, observations) and np.array_equal(again_rewards, rewards), step
        bases += just_rebased(batch.copies[0])
        if bases == 3 and not clones:  # right after the third base: the batch pickled and deep-copied
            clones = [pickle.loads(pickle.dumps(batch)), copy.deepcopy(batch)]
    assert bases >= 8 and batch.active.all()


def test_a_pickle_of_a_release_without_re_bases_still_loads():
    """Earlier pickles hold config, spaces, RNG state and a log from the reset (no trails, no bases): they replay."""
    env = teamgym.make("Navigation-v0", max_cycles=500)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(30):
        env.step({a: rng.uniform(-0.3, 0.3, 2).astype(np.float32) for a in env.agents})
    state = env.__getstate__()
    assert state["log"][0][0] == "reset"
    old = {key: state[key] for key in ("render_mode", "config", "log", "np_random", "spaces")}
    clone = type(env).__new__(type(env))
    clone.__setstate__(copy.deepcopy(old))
    assert clone.trajectories() == env.trajectories()
    actions = {a: np.float32([0.1, 0.2]) for a in env.agents}
    assert outcome(clone, clone.step(dict(actions))) == outcome(env, env.step(dict(actions)))


@pytest.mark.parametrize("env_id", ["Navigation-v0", "BoxPushing-v0"])
def test_an_episode_that_ends_at_a_base_takes_no_snapshot_and_its_copies_still_match(monkeypatch, env_id):
    """The step that ends the episode (here at the cycle limit, exactly ``rebase_cycles`` in) makes no base: no step follows it.

    Pickles and deep copies of the finished env replay from the reset and end alike.
    """
    monkeypatch.setattr(teamgym.env_class(env_id), "rebase_cycles", 30)
    env = teamgym.make(env_id, max_cycles=30)
    _, infos = env.reset(seed=SEED)
    rng = np.random.default_rng(5)
    while env.agents:
        result = env.step(random_actions(env, infos, rng))
        infos = result[-1]
    assert env.cycles == 30 and env._log[0][0] == "reset" and len(env._log) == 31
    for clone in (pickled(env), copy.deepcopy(env)):
        assert clone.cycles == 30 and not clone.agents and clone._log[0][0] == "reset"
        assert np.array_equal(clone.state(), env.state())
