"""Malformed map files give a one-line ConfigError naming ``map`` and the file, for both map kinds.

Office maps (Exploration-v0) and graph maps (Rendezvous-v0) share one loader policy
(``teamgym.maps.jsonfile``); scenario files (``teamgym.maps.scenarios``) use it too.
"""

import itertools
import json
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import teamgym
from teamgym.envs.config import ConfigError
from teamgym.envs.exploration.config import ExplorationConfig
from teamgym.envs.rendezvous.config import RendezvousConfig
from teamgym.maps.graph import GRAPH_DIR
from teamgym.maps.jsonfile import MAX_BYTES, MAX_DEPTH, MapError, parse_json
from teamgym.maps.model import DATA_DIR
from teamgym.maps.scenarios import SCENARIO_DIR, load_scenario

#: Env id -> (a valid map file of its kind, the key of its list of places/sectors, one number's path in it).
KINDS = {
    "Exploration-v0": (DATA_DIR / "office12.json", "sectors", ("size", 0)),
    "Rendezvous-v0": (GRAPH_DIR / "square4.json", "places", ("places", 0, "x")),
}
_names = itertools.count()


def base(env_id: str) -> dict:
    return json.loads(KINDS[env_id][0].read_text())


def with_number(env_id: str, literal: str) -> bytes:
    """The valid map with one number replaced by the raw JSON ``literal``."""
    data = base(env_id)
    *parents, last = KINDS[env_id][2]
    item = data
    for key in parents:
        item = item[key]
    item[last] = "@NUMBER@"
    return json.dumps(data).replace('"@NUMBER@"', literal).encode()


def edited(env_id: str, change) -> bytes:
    data = base(env_id)
    change(data, KINDS[env_id][1])
    return json.dumps(data).encode()


MALFORMED = {
    "5000-digit integer": lambda e: with_number(e, "9" * 5000),
    "NaN literal": lambda e: with_number(e, "NaN"),
    "Infinity literal": lambda e: with_number(e, "Infinity"),
    "-Infinity literal": lambda e: with_number(e, "-Infinity"),
    "number out of range": lambda e: with_number(e, "1e999"),
    "50,000 nested [": lambda e: b"[" * 50_000,
    "closed nesting deeper than the limit": lambda e: with_number(e, "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1)),
    "non-UTF-8 bytes": lambda e: b'{"name": "\xff\xfe"}',
    "huge file": lambda e: b" " * (MAX_BYTES + 1) + b"{}",
    "empty file": lambda e: b"",
    "truncated": lambda e: KINDS[e][0].read_bytes()[:50],
    "top level a list": lambda e: b"[]",
    "repeated key": lambda e: b'{"name": "a", "name": "b"}',
    "places a string": lambda e: edited(e, lambda d, k: d.__setitem__(k, "none")),
    "an item a number": lambda e: edited(e, lambda d, k: d[k].__setitem__(0, 7)),
    "a coordinate a string": lambda e: with_number(e, '"12"'),
    "a coordinate a bool": lambda e: with_number(e, "true"),
    "missing places": lambda e: edited(e, lambda d, k: d.pop(k)),
    "missing id": lambda e: edited(e, lambda d, k: d[k][0].pop("id")),
}


def write(tmp_path, content: bytes):
    path = tmp_path / f"map_{next(_names)}.json"  # a new name each time: configs cache maps by path
    path.write_bytes(content)
    return path


def assert_names_map(error: Exception, path) -> None:
    message = str(error)
    assert "\n" not in message, message[:300]
    assert "map=" in message and str(path) in message, message[:300]


@pytest.mark.parametrize("env_id", sorted(KINDS))
@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_a_malformed_map_file_gives_a_one_line_config_error(tmp_path, env_id, case):
    path = write(tmp_path, MALFORMED[case](env_id))
    with pytest.raises(ConfigError) as caught:
        teamgym.make(env_id, map=str(path))
    assert_names_map(caught.value, path)


@pytest.mark.parametrize("env_id", sorted(KINDS))
def test_the_valid_base_maps_load(tmp_path, env_id):
    env = teamgym.make(env_id, map=str(write(tmp_path, KINDS[env_id][0].read_bytes())))
    env.reset(seed=0)
    env.close()


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4),
    max_leaves=12,
)
CONFIGS = {"Exploration-v0": ExplorationConfig, "Rendezvous-v0": RendezvousConfig}


def _replace(data, path: list[int], value):
    """``data`` with the subtree reached by the indices ``path`` (taken modulo each container's size) replaced."""
    if not path or not isinstance(data, (list, dict)) or not data:
        return value
    keys = list(data) if isinstance(data, dict) else list(range(len(data)))
    key = keys[path[0] % len(keys)]
    data[key] = _replace(data[key], path[1:], value)
    return data


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(env_id=st.sampled_from(sorted(KINDS)), where=st.lists(st.integers(0, 20), max_size=4), value=JSON)
def test_any_subtree_replaced_gives_a_valid_map_or_a_config_error_naming_map(tmp_path, env_id, where, value):
    text = json.dumps(_replace(base(env_id), where, value), allow_nan=True)  # NaN/Infinity literals included
    path = write(tmp_path, text.encode())
    try:
        CONFIGS[env_id].from_kwargs(map=str(path))
    except ConfigError as error:
        assert_names_map(error, path)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("[" * 50_000, f"nested deeper than {MAX_DEPTH} levels"),
        ("1" * 19, "an integer literal of 19 digits"),
        ("-1e400", "out of range"),
        ("NaN", "NaN is not a JSON number"),
        ('{"a": 1, "a": 2}', "key 'a' repeated"),
        ("{", "Expecting property name"),
    ],
)
def test_parse_json_names_the_source_and_the_reason(text, reason):
    with pytest.raises(MapError, match="^here: not valid JSON") as caught:
        parse_json(text, "here")
    assert reason in str(caught.value)


def test_parse_json_keeps_valid_numbers():
    assert parse_json('{"x": [1, -2.5, 123456789012345678, 1e300]}', "s") == {"x": [1, -2.5, 123456789012345678, 1e300]}
    assert math.isfinite(parse_json("1e308", "s"))


@pytest.mark.parametrize("name", ["paper003_fig5", "paper003_fig8"])
def test_shipped_scenarios_load(name):
    assert load_scenario(name)["graph"] == name


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.pop("graph"), "top level: missing key 'graph'"),
        (lambda d: d.__setitem__("robots", {}), "top level.robots: expected a list"),
        (lambda d: d["robots"][0].__setitem__("agent", True), "robots[0].agent: expected a int"),
        (lambda d: d["blocked"][0].__setitem__("detected", []), "blocked[0]: from_step must be >= 0"),
        (lambda d: d["blocked"][0]["detected"][0].pop("place"), "blocked[0].detected[0]: missing key 'place'"),
    ],
)
def test_malformed_scenarios_give_a_map_error_naming_the_item(tmp_path, change, message):
    data = json.loads((SCENARIO_DIR / "paper003_fig5.json").read_text())
    change(data)
    path = write(tmp_path, json.dumps(data).encode())
    with pytest.raises(MapError) as caught:
        load_scenario(path)
    assert str(caught.value).startswith(f"{path}: ") and message in str(caught.value)


def test_scenario_files_share_the_loader_policy(tmp_path):
    path = write(tmp_path, b'{"name": NaN}')
    with pytest.raises(MapError, match="NaN is not a JSON number"):
        load_scenario(path)
