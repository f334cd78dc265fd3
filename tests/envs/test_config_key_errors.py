"""Config errors name the key that is wrong (issue 23, items 10-12).

Every key is range-checked on its own before any check that ties keys together, and a check
that ties keys together names every key involved. So a config that differs from a valid one in
one key either builds or is refused with a message naming that key.
"""

import dataclasses
import typing
from typing import Literal, get_args, get_origin

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import teamgym
from teamgym.envs.config import MAX_CYCLES, ConfigError
from teamgym.envs.examples.beacon import BeaconConfig

CONFIGS = [teamgym.env_class(env_id).config_class for env_id in teamgym.envs()] + [BeaconConfig]
SCALARS = (int, float, bool)


def scalar_keys(config_class) -> list[tuple[str, object]]:
    hints = typing.get_type_hints(config_class)
    out = []
    for f in dataclasses.fields(config_class):
        hint = hints[f.name]
        if hint in SCALARS or get_origin(hint) is Literal:
            out.append((f.name, hint))
    return out


CASES = [(cls, key, hint) for cls in CONFIGS for key, hint in scalar_keys(cls)]


def values_for(hint):
    if hint is bool:
        return st.booleans()
    if get_origin(hint) is Literal:
        return st.sampled_from(get_args(hint))
    ints = st.one_of(st.integers(-(10**12), 10**12), st.sampled_from([-1, 0, 1, 2, 10**9, 10**18]))
    if hint is int:
        return ints
    tiny = st.sampled_from([2.2e-308, 5e-324, -0.0, 1e-12, 1e300, -1e300])
    return st.one_of(st.floats(allow_nan=False, allow_infinity=False), ints.map(float), tiny)


@pytest.mark.parametrize(("config_class", "key", "hint"), CASES, ids=[f"{c.__name__}.{k}" for c, k, _ in CASES])
@settings(max_examples=30, deadline=None, database=None)
@given(data=st.data())
def test_a_config_wrong_in_one_key_names_that_key(config_class, key, hint, data):
    value = data.draw(values_for(hint))
    try:
        config = config_class(**{key: value})
    except ConfigError as error:
        message = str(error)
        assert f"{key}=" in message, f"changing {key} alone gave an error that does not name it: {message}"
        assert "\n" not in message
        return
    assert 1 <= config.cycle_limit <= MAX_CYCLES


@pytest.mark.parametrize(
    ("env_id", "config", "named"),
    [
        ("Rendezvous-v0", {"max_speed": 200}, "max_speed=200"),  # was reported as a substeps error
        ("BoxPushing-v0", {"box_friction": 2.13}, "box_friction=2.13"),  # was reported as a light_box_mass error
        ("Foraging-v0", {"dt": 2.2e-308}, "dt=2.2e-308"),  # make() passed, reset() overflowed
        ("Foraging-v0", {"robots_per_target": -1, "task": "consume"}, "robots_per_target=-1"),  # was accepted
        ("Navigation-v0", {"substeps": 1}, "max_wheel_speed=0.4"),  # a cross-key check names every key
    ],
)
def test_reported_cases_name_the_key(env_id, config, named):
    with pytest.raises(ConfigError, match=named.replace(".", r"\.")):
        teamgym.make(env_id, **config)


def test_derived_episode_length_is_bounded():
    config = teamgym.env_class("Foraging-v0").config_class(dt=1e-4, time_limit=100_000.0, max_cycles=MAX_CYCLES)
    assert config.cycle_limit == 10**9
    with pytest.raises(ConfigError, match="max_cycles=.*must be in"):
        teamgym.make("Navigation-v0", max_cycles=MAX_CYCLES + 1)
