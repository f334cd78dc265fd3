"""Every observation of every env is finite and inside its (finite) space, in extreme valid configs too.

Hypothesis draws configs at the edges of what each config class allows (sensor noise at its
maximum, the smallest and largest arenas, robot and object counts, top speeds, no walls) for
every env id × action type × ``obs_format``; a short random rollout then checks each
observation. A second test puts each newly bounded sensor key just above its maximum.
"""

import math
import re
import typing

import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import teamgym
from teamgym.envs.config import ConfigError

STEPS = 6
#: Short episodes: macro actions (operators, next place) end with the episode, and rollouts stay cheap.
EPISODE = {"max_cycles": 40}


def combos() -> list[tuple[str, str, str]]:
    out = []
    for env_id in teamgym.envs():
        kinds = typing.get_args(typing.get_type_hints(teamgym.env_class(env_id).config_class)["action_type"])
        out += [(env_id, kind, obs_format) for kind in kinds for obs_format in ("flat", "dict")]
    return out


def one_of(*values):
    return st.sampled_from(values)


def speed_substeps(speed: float) -> int:
    """Substeps that keep a body at ``speed`` within 5 mm per substep at Δt = 0.1 s."""
    return max(20, math.ceil(speed * 0.1 / 0.005))


@st.composite
def box_pushing(draw, v1: bool):
    w, h = draw(one_of(0.4, 1.1, 10.0)), draw(one_of(0.4, 0.9, 10.0))
    noise = draw(one_of(0.0, 1.0, 10.0))
    limits = teamgym.env_class("BoxPushing-v1" if v1 else "BoxPushing-v0").config_class.READING_LIMITS
    sensor_range = draw(one_of(0.02, 0.1, 10.0))
    config = {
        "n_robots": draw(one_of(1, 4, 16)),
        "n_light_boxes": draw(one_of(0, 1, 8)),
        "n_heavy_boxes": draw(one_of(0, 1, 8)),
        "table_width": w,
        "table_height": h,
        "lamp": (w + draw(one_of(0.001, 1.0)), h / 2),
        "light_shadows": draw(st.booleans()),
        "observe_stall": draw(st.booleans()),
        "sensor_range": sensor_range,
        "max_wheel_speed": draw(one_of(0.4, 10.0)),
        "noise": noise,
    }
    if noise:  # every noise level at its maximum
        for key in ("light_noise", "light_noise_relative", "light_gain_spread", "sensor_noise_relative"):
            config[key] = limits[key][1] / noise
        config |= {"encoder_noise": 1.0 / noise, "motor_noise": 1.0 / noise, "encoder_resolution": math.pi / 4}
        config["sensor_noise"] = sensor_range / noise
    config["substeps"] = speed_substeps(config["max_wheel_speed"])
    return config


@st.composite
def navigation(draw):
    walls = draw(st.booleans())
    speed, obstacle_speed = draw(one_of(0.4, 10.0)), draw(one_of(0.0, 0.2, 10.0))
    sensor_range = draw(one_of(0.01, 10.0))
    return {
        "n_robots": draw(one_of(1, 3, 64)),
        "n_obstacles": draw(one_of(0, 2, 32)),
        "arena_size": draw(one_of(0.5, 2.0, 100.0)),
        "robot_radius": draw(one_of(0.005, 0.0275, 0.1)),
        "walls": walls,
        "obstacle_motion": "bounce" if walls else draw(one_of("bounce", "straight")),
        "max_wheel_speed": speed,
        "v_opt": speed / 2,
        "obstacle_speed": obstacle_speed,
        "obstacle_radius": draw(one_of(0.01, 0.08)),
        "min_goal_distance": 0.0,
        "sensor_range": sensor_range,
        "sensor_noise": sensor_range,
        "local_features": draw(st.booleans()),
        "mate_goals": draw(st.booleans()),
        "virtual_forces": draw(st.booleans()),
        "actuation_delay": draw(one_of(0.0, 0.1)),
        "substeps": speed_substeps(max(speed, obstacle_speed)),
    }


@st.composite
def exploration(draw):
    sensor_range = draw(one_of(0.01, 0.1, 10.0))
    return {
        "map": draw(one_of("office12", "lab7")),
        "n_robots": draw(one_of(1, 3, 16)),
        "furniture": draw(st.booleans()),
        "max_speed": draw(one_of(0.01, 0.4)),
        "sensor_range": sensor_range,
        "sensor_noise": sensor_range,
        "door_resample_period": draw(one_of(0.0, 0.5)),
    }


@st.composite
def rendezvous(draw):
    sensor_range = draw(one_of(0.01, 0.1, 10.0))
    return {
        "map": draw(one_of("square4", "paper003_fig8", "lattice30")),
        "n_robots": draw(one_of(2, 4, 8)),
        "scale": draw(one_of(0.05, 0.5, 100.0)),
        "corridor_walls": draw(st.booleans()),
        "protocol_messages": draw(st.booleans()),
        "message_len": draw(one_of(8, 128)),
        "block_rate": draw(one_of(0.0, 1.0)),
        "max_speed": 0.4,
        "sensor_range": sensor_range,
        "sensor_noise": sensor_range,
    }


@st.composite
def foraging(draw):
    w, h = draw(one_of(0.5, 3.0, 50.0)), draw(one_of(0.5, 2.4, 50.0))
    speed = draw(one_of(0.01, 0.5, 5.0))
    return {
        "field_size": (w, h),
        "cell_size": min(w, h) / 2 if draw(st.booleans()) else min(max(0.05, max(w, h) / 30), min(w, h) / 2),
        "n_robots": draw(one_of(1, 2, 16)),
        "n_targets": draw(one_of(1, 3, 32)),
        "task": draw(one_of("consume", "surround")),
        "robots_per_target": 1,
        "robot_radius": draw(one_of(0.02, 0.09)),
        "reach_radius": 0.2,
        "max_speed": speed,
        "camera_range": draw(one_of(0.1, 1.0, 100.0)),
        "camera_fov": draw(one_of(0.05, 1.28, 2 * math.pi)),
        "vision_noise": draw(one_of(0.0, 10.0)),
        "rotational_certainty": draw(one_of(1e-6, 0.9, 1.0)),
        "odometry_rotation_noise": draw(one_of(0.0, 1.0)),
        "odometry_distance_noise": draw(one_of(0.0, 1.0)),
        "observe_world_model": draw(st.booleans()),
        "observe_novelty": draw(st.booleans()),
        "world_model_sources": draw(st.sampled_from(["all", "own"])),
        "comm_throughput": draw(one_of(0.0, 1.0)),
        "substeps": speed_substeps(speed),
    }


STRATEGIES = {
    "BoxPushing-v0": box_pushing(False),
    "BoxPushing-v1": box_pushing(True),
    "Navigation-v0": navigation(),
    "Exploration-v0": exploration(),
    "Rendezvous-v0": rendezvous(),
    "Foraging-v0": foraging(),
}


def test_every_env_has_a_strategy():
    assert sorted(STRATEGIES) == teamgym.envs()


def assert_finite_space(space: spaces.Space) -> None:
    boxes = space.spaces.values() if isinstance(space, spaces.Dict) else [space]
    for box in boxes:
        assert isinstance(box, spaces.Box)
        assert np.all(np.isfinite(box.low)) and np.all(np.isfinite(box.high)), box


def assert_valid(env, observations: dict) -> None:
    for agent, obs in observations.items():
        for name, value in obs.items() if isinstance(obs, dict) else [("", obs)]:
            assert np.all(np.isfinite(value)), f"{agent} {name}: {value}"
        assert env.observation_space(agent).contains(obs), {k: v for k, v in env.decode(obs).items()}


def sample(env, agent: str, infos: dict):
    mask = infos.get(agent, {}).get("action_mask")
    return env.action_space(agent).sample(mask=mask) if mask is not None else env.action_space(agent).sample()


@pytest.mark.parametrize(("env_id", "action_type", "obs_format"), combos())
@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(data=st.data())
def test_extreme_configs_keep_every_observation_inside_its_finite_space(env_id, action_type, obs_format, data):
    config = {**data.draw(STRATEGIES[env_id]), **EPISODE, "action_type": action_type, "obs_format": obs_format}
    config["comm_dim"] = data.draw(one_of(0, 2))
    try:
        env = teamgym.make(env_id, **config)
    except ConfigError:
        assume(False)  # an extreme combination the config refuses (e.g. too many robots for the arena)
    for agent in env.possible_agents:
        assert_finite_space(env.observation_space(agent))
        env.action_space(agent).seed(0)
    # Seeds 0-31: the scenes make() tries when it checks that a config can be placed.
    try:
        observations, infos = env.reset(seed=data.draw(st.integers(0, 31)))
    except ConfigError:
        assume(False)  # a scene that could not be placed for this seed
    assert_valid(env, observations)
    for _ in range(STEPS):
        if not env.agents:
            break
        observations, _, _, _, infos = env.step({a: sample(env, a, infos) for a in env.agents})
        assert_valid(env, observations)
    env.close()


def new_limits() -> list[tuple[str, str]]:
    """(env id, key) for every key bounded by a config's ``READING_LIMITS``."""
    out = []
    for env_id in teamgym.envs():
        limits = getattr(teamgym.env_class(env_id).config_class, "READING_LIMITS", {})
        out += [(env_id, key) for key in limits]
    return out


def test_the_bounded_keys_include_every_noise_level():
    keys = {key for _, key in new_limits()}
    assert {"sensor_noise", "light_noise", "light_gain_spread", "encoder_noise", "motor_noise", "noise"} <= keys


@pytest.mark.parametrize(("env_id", "key"), new_limits())
def test_a_bounded_key_just_above_its_maximum_is_refused_naming_it(env_id, key):
    config_class = teamgym.env_class(env_id).config_class
    high = config_class.READING_LIMITS[key][1]
    value = high * (1 + 1e-9) + 1e-12
    with pytest.raises(ConfigError, match=re.escape(f"{key}={value!r} is invalid; it must be in")) as caught:
        teamgym.make(env_id, substeps=1000, **{key: value})
    assert "\n" not in str(caught.value)
    # The maximum itself is allowed (with the keys it must fit together with).
    companions = {"noise": dict.fromkeys(getattr(config_class, "NOISE_KEYS", ()), 0.0), "sensor_noise": {"sensor_range": 10.0}}
    teamgym.make(env_id, substeps=1000, **companions.get(key, {}), **{key: high}).close()


@pytest.mark.parametrize("env_id", sorted({env_id for env_id, key in new_limits() if key == "sensor_noise"}))
def test_proximity_noise_above_the_range_is_refused_naming_both(env_id):
    with pytest.raises(ConfigError, match=r"sensor_noise=0\.3, sensor_range=0\.2 do not fit together"):
        teamgym.make(env_id, sensor_noise=0.3, sensor_range=0.2)


@pytest.mark.parametrize(("key", "value"), [("light_gain_spread", 0.2), ("encoder_noise", 0.5), ("light_noise", 2.0)])
def test_box_pushing_noise_levels_hold_their_range_after_scaling(key, value):
    with pytest.raises(ConfigError, match=re.escape(f"noise=6.0, {key}={value} do not fit together; noise × {key}")):
        teamgym.make("BoxPushing-v0", noise=6.0, **{key: value})
    teamgym.make("BoxPushing-v0", noise=1.0, **{key: value}).close()
