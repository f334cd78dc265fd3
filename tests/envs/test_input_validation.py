"""Bad actions and bad calls raise clear errors and leave the episode exactly as it was."""

import copy
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import teamgym

ZERO = np.zeros(2, dtype=np.float32)
HYPOTHESIS = settings(max_examples=100, deadline=None, database=None)


def make(action_type="velocity", **config):
    kwargs = dict(n_robots=3, n_obstacles=1, max_cycles=1000, action_type=action_type)
    kwargs.update(config)
    return teamgym.make("Navigation-v0", **kwargs)


def neutral(env):
    return {a: (0 if hasattr(env.action_space(a), "n") else ZERO) for a in env.agents}


def snapshot(env):
    return env.state().copy(), env.cycles, list(env.agents)


def assert_rejected(env, actions, errors, *fragments):
    """``env.step(actions)`` raises one of ``errors`` whose message contains every fragment, and
    the env then continues exactly like a copy taken before the call."""
    twin = copy.deepcopy(env)
    before = snapshot(env)
    with pytest.raises(errors) as info:
        env.step(actions)
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in error message {message!r}"
    state, cycles, agents = snapshot(env)
    np.testing.assert_array_equal(state, before[0])
    assert (cycles, agents) == before[1:]
    for _ in range(3):
        if not env.agents:
            break
        actions = neutral(env)
        a = env.step(actions)
        b = twin.step(actions)
        for agent in a[0]:
            np.testing.assert_array_equal(a[0][agent], b[0][agent])
        assert a[1:] == b[1:]
    return message


@pytest.fixture
def velocity_env():
    env = make()
    env.reset(seed=0)
    env.step(neutral(env))
    return env


@pytest.fixture
def heading_env():
    env = make("heading")
    env.reset(seed=0)
    env.step(neutral(env))
    return env


def with_action(env, agent, action):
    actions = neutral(env)
    actions[agent] = action
    return actions


# -- Box actions -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("action", "fragment"),
    [
        ([1.0, 0.0], "1.0"),
        (np.array([0.0, -100.0], dtype=np.float32), "-100.0"),
        ([0.41, 0.0], "0.41"),
        ([math.nan, 0.0], "NaN"),
        ([0.0, math.inf], "inf"),
        (np.array([-math.inf, 0.0]), "inf"),
    ],
    ids=["v-too-big", "w-too-small", "v-just-over", "nan", "inf", "minus-inf"],
)
def test_out_of_space_or_non_finite_box_action(velocity_env, action, fragment):
    assert_rejected(velocity_env, with_action(velocity_env, "robot_1", action), ValueError, "robot_1", fragment)


@pytest.mark.parametrize(
    "action",
    [[0.1], [0.1, 0.2, 0.3], [[0.1, 0.2]], np.zeros((2, 1)), 0.1, np.float32(0.0)],
    ids=["short", "long", "nested", "column", "scalar", "np-scalar"],
)
def test_wrong_shape_box_action(velocity_env, action):
    assert_rejected(velocity_env, with_action(velocity_env, "robot_2", action), ValueError, "robot_2", "shape")


@pytest.mark.parametrize(
    "action",
    [
        "ab",
        {"v": 0.1},
        object(),
        [0.1, "x"],
        pytest.param(["0.1", "0.2"], id="numeric-strings"),
        pytest.param(np.array(["0.1", "0.2"]), id="numeric-str-array"),
        pytest.param(
            np.array([0.1 + 0j, 0.0]),
            marks=[pytest.mark.filterwarnings("ignore:Casting complex values")],
            id="complex",
        ),
    ],
)
def test_wrong_type_box_action(velocity_env, action):
    assert_rejected(velocity_env, with_action(velocity_env, "robot_0", action), (TypeError, ValueError), "robot_0")


def test_box_action_dtypes_accepted(velocity_env):
    env = velocity_env
    for action in ([0.1, 0.2], (0.1, 0.2), np.array([0.1, 0.2]), np.array([0.1, 0.2], dtype=np.float32), np.array([0, 1])):
        env.step({a: action for a in env.agents})
    high = env.action_space("robot_0").high
    env.step({a: high.copy() for a in env.agents})  # the bounds themselves are in the space
    env.step({a: -high for a in env.agents})


# -- Discrete actions --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("action", "error", "fragment"),
    [
        (True, TypeError, "True"),
        (np.bool_(False), TypeError, "False"),
        (5, ValueError, "5"),
        (-1, ValueError, "-1"),
        (2.5, ValueError, "2.5"),
        ("2", TypeError, "'2'"),
        ([1, 2], TypeError, "[1, 2]"),
        (None, TypeError, "None"),
        (math.nan, ValueError, "nan"),
        (np.array([[3]]), TypeError, "3"),
    ],
    ids=["bool", "np-bool", "too-big", "negative", "fraction", "string", "list", "none", "nan", "2d"],
)
def test_bad_discrete_action(heading_env, action, error, fragment):
    assert_rejected(heading_env, with_action(heading_env, "robot_1", action), error, "robot_1", fragment)


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64, np.intp])
def test_discrete_accepts_numpy_ints(heading_env, dtype):
    env = heading_env
    twin = copy.deepcopy(env)
    a = env.step({agent: dtype(4) for agent in env.agents})
    b = twin.step({agent: 4 for agent in twin.agents})
    for agent in a[0]:
        np.testing.assert_array_equal(a[0][agent], b[0][agent])
    env.step({agent: np.array(1, dtype=dtype) for agent in env.agents})
    env.step({agent: np.array([0], dtype=dtype) for agent in env.agents})


# -- the actions dict and the episode protocol ----------------------------------------------


@pytest.mark.parametrize("actions", [[ZERO, ZERO, ZERO], (ZERO,), None, "robot_0", np.zeros((3, 2))])
def test_non_dict_actions(velocity_env, actions):
    assert_rejected(velocity_env, actions, TypeError, "dict", type(actions).__name__)


def test_unknown_agent(velocity_env):
    actions = neutral(velocity_env)
    actions["robot_7"] = ZERO
    assert_rejected(velocity_env, actions, KeyError, "robot_7")
    assert_rejected(velocity_env, {**neutral(velocity_env), 0: ZERO}, KeyError, "0")


def test_missing_agent(velocity_env):
    actions = neutral(velocity_env)
    del actions["robot_2"]
    assert_rejected(velocity_env, actions, ValueError, "robot_2")
    assert_rejected(velocity_env, {}, ValueError, "robot_0", "robot_1", "robot_2")


def drive_home(env, agent, steps=400):
    """Steer ``agent`` to its goal with a simple heading controller; the others stand still."""
    observations, _ = env.reset(seed=3)
    omega_max = float(env.action_space(agent).high[1])
    for _ in range(steps):
        fields = env.decode(observations[agent])
        gx, gy = fields["goal_offset"]
        error = math.remainder(math.atan2(gy, gx) - fields["pose"][2], math.tau)
        command = [0.3 * max(math.cos(error), 0.0), float(np.clip(6 * error, -omega_max, omega_max))]
        actions = {a: ZERO for a in env.agents}
        actions[agent] = np.array(command, dtype=np.float32)
        observations, _, terminations, _, _ = env.step(actions)
        if terminations[agent]:
            return
    raise AssertionError(f"{agent} did not reach its goal")


def test_actions_for_finished_agent():
    env = make(n_obstacles=0, arena_size=1.0, min_goal_distance=0.3)
    drive_home(env, "robot_0")
    assert env.agents == ["robot_1", "robot_2"]
    message = assert_rejected(env, {**neutral(env), "robot_0": ZERO}, ValueError, "robot_0")
    assert "over" in message
    env.step(neutral(env))  # the others play on


def test_step_before_reset_and_after_end():
    env = make(max_cycles=2)
    with pytest.raises(teamgym.EpisodeOverError, match="reset"):
        env.step({})
    with pytest.raises(teamgym.EpisodeOverError, match="reset"):
        env.step(neutral(make()))
    env.reset(seed=1)
    env.step(neutral(env))
    _, _, _, truncations, _ = env.step(neutral(env))
    assert all(truncations.values()) and env.agents == []
    before = env.state().copy()
    for actions in ({}, {"robot_0": ZERO}):
        with pytest.raises(teamgym.EpisodeOverError, match="reset"):
            env.step(actions)
    np.testing.assert_array_equal(env.state(), before)
    env.reset(seed=1)
    assert env.agents == env.possible_agents


def test_reset_options_must_be_dict():
    env = make()
    with pytest.raises(TypeError, match="options"):
        env.reset(seed=0, options=["x"])


def test_unknown_agent_spaces():
    env = make()
    for method in (env.observation_space, env.action_space):
        with pytest.raises(KeyError, match="robot_9"):
            method("robot_9")


# -- property tests ----------------------------------------------------------------------


def in_bounds(space):
    low, high = space.low.astype(float), space.high.astype(float)
    return st.tuples(*[st.floats(min_value=lo, max_value=hi) for lo, hi in zip(low, high)])


@pytest.fixture(scope="module")
def shared_velocity_env():
    return make()


@pytest.fixture(scope="module")
def shared_wheels_env():
    return make("wheels")


@pytest.fixture(scope="module")
def shared_heading_env():
    return make("heading")


@HYPOTHESIS
@given(data=st.data(), seed=st.integers(0, 2**16), as_type=st.sampled_from(["list", "float32", "float64"]))
def test_any_finite_in_bounds_action_is_accepted(shared_velocity_env, shared_wheels_env, data, seed, as_type):
    for env in (shared_velocity_env, shared_wheels_env):
        env.reset(seed=seed)
        space = env.action_space("robot_0")
        for _ in range(2):
            actions = {}
            for agent in env.agents:
                values = data.draw(in_bounds(space))
                actions[agent] = list(values) if as_type == "list" else np.array(values, dtype=as_type)
            observations, rewards, *_ = env.step(actions)
            for agent, obs in observations.items():
                assert env.observation_space(agent).contains(obs)
                assert np.all(np.isfinite(obs))
                assert np.isfinite(rewards[agent])


def bad_value(low, high):
    return st.one_of(
        st.floats(min_value=math.nextafter(high, math.inf), allow_infinity=False),
        st.floats(max_value=math.nextafter(low, -math.inf), allow_infinity=False),
        st.sampled_from([math.nan, math.inf, -math.inf]),
    )


@HYPOTHESIS
@given(
    seed=st.integers(0, 2**16),
    agent_index=st.integers(0, 2),
    dim=st.integers(0, 1),
    data=st.data(),
    warmup=st.integers(0, 3),
)
def test_out_of_bounds_or_non_finite_is_rejected_and_harmless(shared_velocity_env, seed, agent_index, dim, data, warmup):
    env = shared_velocity_env
    env.reset(seed=seed)
    for _ in range(warmup):
        env.step(neutral(env))
    agent = env.agents[agent_index]
    space = env.action_space(agent)
    action = np.zeros(2)
    action[dim] = data.draw(bad_value(float(space.low[dim]), float(space.high[dim])))
    # Bounds are the space's float32 values, as in space.contains: a value that rounds onto a bound is inside.
    assume(not (space.low[dim] <= np.float32(action[dim]) <= space.high[dim]))
    action[1 - dim] = data.draw(in_bounds(space))[1 - dim]
    assert_rejected(env, with_action(env, agent, action), ValueError, repr(agent))


@HYPOTHESIS
@given(
    seed=st.integers(0, 2**16),
    value=st.integers(0, 4),
    dtype=st.sampled_from([np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint32, np.uint64]),
    shape=st.sampled_from([(), (1,)]),
)
def test_discrete_numpy_ints_are_accepted(shared_heading_env, seed, value, dtype, shape):
    env = shared_heading_env
    env.reset(seed=seed)
    observations, *_ = env.step({a: np.full(shape, value, dtype=dtype) if shape else dtype(value) for a in env.agents})
    assert all(env.observation_space(a).contains(o) for a, o in observations.items())


@HYPOTHESIS
@given(seed=st.integers(0, 2**16), value=st.integers().filter(lambda v: not 0 <= v < 5), agent_index=st.integers(0, 2))
def test_discrete_out_of_range_is_rejected(shared_heading_env, seed, value, agent_index):
    env = shared_heading_env
    env.reset(seed=seed)
    agent = env.agents[agent_index]
    # Python ints beyond int64 cannot even become a numpy integer: TypeError is fine there.
    assert_rejected(env, with_action(env, agent, value), (ValueError, TypeError), repr(agent), str(value))


def test_action_at_float32_bounds_is_accepted_as_contains_says():
    env = teamgym.make("Navigation-v0")
    env.reset(seed=0)
    space = env.action_space("robot_0")
    edge = [0.4, env.robots["robot_0"].spec.max_turn_rate]  # float64 values that round onto the float32 bounds
    assert space.contains(np.asarray(edge, dtype=np.float32))
    env.step({a: edge if a == "robot_0" else np.zeros(2) for a in env.agents})
