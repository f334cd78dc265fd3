"""The core's contracts on every registered env: config validation, spaces and formats, infos, actions."""

import copy
import dataclasses
import gc
import typing
import weakref

import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import given, settings
from hypothesis import strategies as st

import teamgym
from teamgym.envs.config import MAX_SUBSTEP_TRAVEL, ConfigError
from teamgym.envs.spaces import ActionChecker, Field, ObservationLayout

ENV_IDS = teamgym.envs()


def action_types(env_id):
    hint = typing.get_type_hints(teamgym.env_class(env_id).config_class)["action_type"]
    return typing.get_args(hint)


CASES = [pytest.param(e, k, id=f"{e}-{k}") for e in ENV_IDS for k in action_types(e)]


def admissible_actions(env, rng):
    actions = {}
    masks = env.action_masks()
    for agent in env.agents:
        space = env.action_space(agent)
        if agent in masks:
            actions[agent] = int(rng.choice(np.flatnonzero(masks[agent])))
        elif isinstance(space, spaces.Discrete):
            actions[agent] = int(rng.integers(space.n))
        else:
            actions[agent] = rng.uniform(space.low, space.high).astype(np.float32)
    return actions


# -- configuration ------------------------------------------------------------------------


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_validation_holds_for_constructor_and_replace(env_id):
    config_class = teamgym.env_class(env_id).config_class
    with pytest.raises(ConfigError, match="max_cycles"):
        config_class(max_cycles=-3)
    with pytest.raises(ConfigError, match="n_robots"):
        dataclasses.replace(config_class(), n_robots=-3)
    with pytest.raises(ConfigError, match="obs_format"):
        config_class(obs_format="bogus")


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_bad_choice_lists_the_choices(env_id):
    with pytest.raises(ConfigError) as error:
        teamgym.make(env_id, action_type="bogus")
    for choice in action_types(env_id):
        assert repr(choice) in str(error.value)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_numpy_scalars_are_accepted_as_config_values(env_id):
    env = teamgym.make(env_id, max_cycles=np.int64(30), dt=np.float32(0.05), n_robots=np.int32(2))
    assert type(env.config.max_cycles) is int and env.config.max_cycles == 30
    assert type(env.config.dt) is float and env.config.n_robots == 2


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize(("dt", "substeps"), [(1.0, 1), (1e300, 20), (0.2, 5)])
def test_substep_travel_is_bounded(env_id, dt, substeps):
    with pytest.raises(ConfigError, match="dt|substeps"):
        teamgym.make(env_id, dt=dt, substeps=substeps)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_robots_stay_in_the_arena_at_the_largest_accepted_substep(env_id):
    # top speed × dt / substeps = MAX_SUBSTEP_TRAVEL: the coarsest stepping the config accepts.
    dt = 0.5
    speed = teamgym.env_class(env_id).config_class().body_speed()
    substeps = int(np.ceil(speed * dt / MAX_SUBSTEP_TRAVEL - 1e-9))
    env = teamgym.make(env_id, dt=dt, substeps=substeps, max_cycles=40)
    env.reset(seed=1)
    width, height = env.world.size
    rng = np.random.default_rng(0)
    while env.agents:
        actions = admissible_actions(env, rng)
        for agent in env.agents:
            space = env.action_space(agent)
            if isinstance(space, spaces.Box):
                actions[agent] = space.high  # full speed
        env.step(actions)
        for robot in env.robots.values():
            x, y = robot.position
            assert -0.01 <= x <= width + 0.01 and -0.01 <= y <= height + 0.01, (robot.name, x, y)


def test_binary_map_file_is_a_config_error_naming_map(tmp_path):
    path = tmp_path / "map.json"
    path.write_bytes(bytes(range(256)))
    with pytest.raises(ConfigError, match="map="):
        teamgym.make("Exploration-v0", map=str(path))


def test_box_pushing_that_cannot_be_placed_fails_at_make():
    with pytest.raises(ConfigError, match="crowded"):
        teamgym.make("BoxPushing-v0", n_robots=16, n_light_boxes=0, n_heavy_boxes=6)


# -- spaces, formats and infos -------------------------------------------------------------


@pytest.mark.parametrize(("env_id", "action_type"), CASES)
def test_dict_format_holds_the_flat_fields(env_id, action_type):
    flat = teamgym.make(env_id, action_type=action_type, max_cycles=20)
    nested = teamgym.make(env_id, action_type=action_type, max_cycles=20, obs_format="dict")
    obs_flat, _ = flat.reset(seed=3)
    obs_dict, _ = nested.reset(seed=3)
    rng_a, rng_b = np.random.default_rng(0), np.random.default_rng(0)
    for _ in range(5):
        for agent, vector in obs_flat.items():
            assert nested.observation_space(agent).contains(obs_dict[agent])
            assert flat.observation_space(agent).contains(vector)
            decoded = flat.decode(vector)
            extra = {nested._mask_field} if nested.action_type.has_masks else set()
            assert set(obs_dict[agent]) == set(decoded) | extra
            for name, value in decoded.items():
                np.testing.assert_array_equal(obs_dict[agent][name], value.astype(obs_dict[agent][name].dtype))
        if not flat.agents:
            break
        obs_flat, *_ = flat.step(admissible_actions(flat, rng_a))
        obs_dict, *_ = nested.step(admissible_actions(nested, rng_b))


@pytest.mark.parametrize(("env_id", "action_type"), CASES)
def test_infos_hold_numbers_and_the_success_contract(env_id, action_type):
    env = teamgym.make(env_id, action_type=action_type, max_cycles=15)
    _, infos = env.reset(seed=0)
    rng = np.random.default_rng(0)
    while True:
        for info in infos.values():
            assert info["success"] == env.episode_success()
            for key, value in info.items():
                assert isinstance(value, (bool, int, float, np.ndarray, np.number, np.bool_)), (key, value)
        if not env.agents:
            break
        *_, infos = env.step(admissible_actions(env, rng))


def test_action_spaces_are_freed_with_their_env():
    env = teamgym.make("Navigation-v0")
    env.reset(seed=0)
    env.step({a: env.action_space(a).sample() for a in env.agents})
    clones = [copy.deepcopy(env) for _ in range(3)]
    refs = [weakref.ref(c.action_space("robot_0")) for c in clones]
    del clones
    gc.collect()
    assert all(ref() is None for ref in refs)


# -- composite actions ---------------------------------------------------------------------


COMPOSITE = spaces.Dict(
    {
        "motion": spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32),
        "message": spaces.Tuple((spaces.Discrete(4), spaces.Box(0.0, 1.0, shape=(3,), dtype=np.float32))),
    }
)


def test_composite_action_is_converted():
    checked = ActionChecker(COMPOSITE).check("robot_0", {"motion": [0.5, -1.0], "message": (np.int64(2), [0, 0.5, 1])})
    assert checked["message"][0] == 2 and isinstance(checked["message"][0], int)
    np.testing.assert_array_equal(checked["motion"], [0.5, -1.0])


@pytest.mark.parametrize(
    ("action", "fragment"),
    [
        ({"motion": [0.5, 2.0], "message": (1, [0, 0, 0])}, r"'robot_0' at 'motion'.*outside"),
        ({"motion": [0.5, 0.0], "message": (7, [0, 0, 0])}, r"at 'message'\[0\].*outside Discrete"),
        ({"motion": [0.5, 0.0], "message": (1, [0, np.nan, 0])}, r"at 'message'\[1\].*NaN"),
        ({"motion": [0.5, 0.0]}, r"expected exactly \['message', 'motion'\]"),
        ({"motion": [0.5, 0.0], "message": (1,)}, r"at 'message'.*tuple of 2"),
        ([0.5, 0.0], r"must be a dict"),
    ],
)
def test_composite_action_errors_name_agent_field_and_value(action, fragment):
    with pytest.raises((ValueError, TypeError), match=fragment):
        ActionChecker(COMPOSITE).check("robot_0", action)


@settings(max_examples=60, deadline=None)
@given(st.floats(allow_nan=True, allow_infinity=True, width=64))
def test_box_checker_agrees_with_contains(value):
    space = spaces.Box(-0.4, 0.4, shape=(1,), dtype=np.float32)
    inside = space.contains(np.asarray([value], dtype=np.float64).astype(np.float32)) if np.isfinite(value) else False
    try:
        ActionChecker(space).check("a", [value])
        accepted = True
    except ValueError:
        accepted = False
    assert accepted == inside


def test_layout_fields_carry_dtype_and_bounds():
    layout = ObservationLayout([Field("image", (4, 4), 0, 255, np.uint8), ("pose", (3,)), Field("mask", (2,), 0, 1, np.int8)])
    space = layout.space("dict")
    assert space["image"].dtype == np.uint8 and space["image"].high.max() == 255
    assert space["mask"].dtype == np.int8 and space["pose"].dtype == np.float32
    flat = layout.space("flat")
    assert flat.shape == (16 + 3 + 2,) and flat.high[0] == 255 and np.isinf(flat.high[16])
    row = np.arange(21, dtype=np.float32)
    as_dict = layout.to_dict(row)
    assert as_dict["image"].dtype == np.uint8 and as_dict["image"][3, 3] == 15
    np.testing.assert_array_equal(layout.decode(as_dict)["pose"], [16, 17, 18])


def test_field_bounds_broadcast_per_element():
    layout = ObservationLayout([Field("pose", (3,), (0.0, 0.0, -np.pi), (2.0, 2.0, np.pi))])
    box = layout.space("dict")["pose"]
    np.testing.assert_allclose(box.high, [2.0, 2.0, np.pi], rtol=1e-6)
    np.testing.assert_allclose(layout.space("flat").low, [0.0, 0.0, -np.pi], rtol=1e-6)


def test_task_fields_may_not_use_the_inbox_names():
    from teamgym.envs.navigation import Navigation

    class Clashing(Navigation):
        def _make_layout(self):
            return super()._make_layout().extended([Field("inbox_mask", (1,))])

    with pytest.raises(ValueError, match="reserved for the message inbox"):
        Clashing()
