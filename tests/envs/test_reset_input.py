"""Bad ``reset`` input (seeds, options) is refused before anything changes (issue 23, items 1 and 3).

After a rejected reset the env pickles, and it and its unpickled copy continue exactly as a twin
that never saw the call.
"""

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import teamgym
from tests.regression import _sample

SMALL = {"Rendezvous-v0": {"max_cycles": 2000}, "Exploration-v0": {"max_cycles": 2000}}
IDS = teamgym.envs()
HYPOTHESIS = settings(max_examples=25, deadline=None, database=None)


def started(env_id: str, steps: int = 2):
    """An env of ``env_id`` reset with seed 3 and stepped ``steps`` times with seeded admissible actions, and its infos."""
    env = teamgym.make(env_id, **SMALL.get(env_id, {}))
    _, infos = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(steps):
        _, _, _, _, infos = env.step({a: _sample(env, a, infos, rng) for a in env.agents})
    return env, infos


def assert_continues_like_twin(env, env_id: str, steps: int = 2) -> None:
    """``env`` pickles, and it and its unpickled copy step exactly as a twin that saw no bad call."""
    twin, infos = started(env_id)
    clone = pickle.loads(pickle.dumps(env))
    rng = np.random.default_rng(1)
    for _ in range(steps):
        if not twin.agents:
            break
        actions = {a: _sample(twin, a, infos, rng) for a in twin.agents}
        expected = twin.step(actions)
        infos = expected[4]
        for other in (env, clone):
            got = other.step(actions)
            for agent, obs in expected[0].items():
                np.testing.assert_array_equal(got[0][agent], obs)
            assert got[1:4] == expected[1:4]
        np.testing.assert_array_equal(env.state(), twin.state())


bad_seeds = st.one_of(
    st.integers(max_value=-1),
    st.floats(allow_nan=True),
    st.text(max_size=5),
    st.booleans(),
    st.lists(st.integers(0, 5), max_size=3),
    st.just(np.float64(2.0)),
    st.just(np.int64(-4)),
)


@pytest.mark.parametrize("env_id", IDS)
def test_a_bad_seed_is_refused_naming_seed_and_changes_nothing(env_id):
    env, _ = started(env_id)
    for seed in (-1, "abc", 1.5, True, [1, 2], np.int64(-4)):
        with pytest.raises((TypeError, ValueError), match=r"^reset seed=.* is invalid; it must be a non-negative int or None$"):
            env.reset(seed=seed)
    assert_continues_like_twin(env, env_id)


@HYPOTHESIS
@given(seed=bad_seeds)
def test_every_bad_seed_is_refused_before_work(seed):
    env, _ = started("Navigation-v0", steps=1)
    log = list(env._log)
    with pytest.raises((TypeError, ValueError), match="seed="):
        env.reset(seed=seed)
    assert env._log == log and env.cycles == 1


def test_numpy_integer_seeds_equal_python_ints():
    a, b = teamgym.make("Navigation-v0"), teamgym.make("Navigation-v0")
    np.testing.assert_array_equal(a.reset(seed=np.int64(7))[0]["robot_0"], b.reset(seed=7)[0]["robot_0"])


@pytest.mark.parametrize("env_id", IDS)
def test_unknown_reset_option_keys_are_refused_by_every_env(env_id):
    env, _ = started(env_id)
    with pytest.raises(ValueError, match=r"unknown option key\(s\) \['no_such_option'\]"):
        env.reset(seed=0, options={"no_such_option": 1})
    with pytest.raises(TypeError, match="options must be a dict"):
        env.reset(seed=0, options=[("targets", 1)])
    assert_continues_like_twin(env, env_id)


scene_values = st.one_of(
    st.none(),
    st.integers(),
    st.text(max_size=4),
    st.lists(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4), max_size=4),
    st.lists(st.tuples(st.floats(-1, 4), st.floats(-1, 4)), min_size=3, max_size=3),
    st.lists(st.tuples(st.floats(-1, 4), st.floats(-1, 4), st.floats()), min_size=2, max_size=2),
)


def _fits(key: str, value) -> bool:
    """Whether ``value`` is a valid Foraging reset option ``key`` (default config), computed independently."""
    shape, margin = {"targets": ((3, 2), 0.0), "starts": ((2, 3), 0.09)}[key]
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        return False
    if array.shape != shape or not np.isfinite(array).all():
        return False
    x, y = array[:, 0], array[:, 1]
    return bool(np.all((x >= margin) & (x <= 3.0 - margin) & (y >= margin) & (y <= 2.4 - margin)))


@HYPOTHESIS
@given(key=st.sampled_from(["targets", "starts"]), value=scene_values)
def test_foraging_scene_options_are_checked_before_anything_changes(key, value):
    env, _ = started("Foraging-v0", steps=1)
    if _fits(key, value):
        env.reset(seed=0, options={key: value})
        return
    log = list(env._log)
    with pytest.raises(ValueError, match=f"^reset option '{key}'=.* is invalid; it must have shape"):
        env.reset(seed=0, options={key: value})
    assert env._log == log and env.cycles == 1


@pytest.mark.parametrize("options", [{"targets": None}, {"starts": [(0.5, 0.5, 0.0)]}, {"targets": [[1.0, 1.0, 1.0]] * 3}])
def test_foraging_after_a_rejected_scene_continues_like_its_twin(options):
    env, _ = started("Foraging-v0")
    with pytest.raises(ValueError, match=next(iter(options))):
        env.reset(seed=0, options=options)
    assert_continues_like_twin(env, "Foraging-v0")


def test_valid_foraging_scene_options_fix_the_scene():
    env = teamgym.make("Foraging-v0")
    targets = [(0.5, 0.5), (1.5, 1.2), (2.5, 2.0)]
    env.reset(seed=0, options={"targets": targets, "starts": [(1.0, 1.0, 0.0), (2.0, 1.0, 1.0)]})
    np.testing.assert_allclose(env.targets, targets)


def test_pettingzoo_probe_key_is_the_one_tolerated_unknown_key():
    """PettingZoo's api tests pass ``{"options": 1}``; it is dropped, and the reset equals one without options."""
    a, b = teamgym.make("Foraging-v0"), teamgym.make("Foraging-v0")
    obs_a, _ = a.reset(seed=2, options={"options": 1})
    obs_b, _ = b.reset(seed=2)
    np.testing.assert_array_equal(obs_a["robot_0"], obs_b["robot_0"])
    assert a.reset_options == {}
    with pytest.raises(ValueError, match=r"\['option'\]"):
        a.reset(seed=2, options={"option": 1})
