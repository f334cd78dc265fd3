"""One info schema per env, fixed from reset (issue 25, deliverables 1 and 2).

Every ``infos[agent]`` holds exactly the keys of ``env.info_schema()`` after reset and every
step, in every episode; masks are in the observation wherever the action type has them.
"""

import numpy as np
import pytest

import teamgym
from baselines.evaluate import evaluate
from baselines.summary import summarise, write_episodes_csv
from tests.regression import _random_value, cases, obs_cases

DISCRETE = {"heading", "primitives", "operator", "next_place", "goto_cell"}
FAMILIES = dict(obs_cases())
for env_id, kind in cases():
    if kind in DISCRETE:
        FAMILIES[f"{env_id}/{kind}/masked"] = (env_id, {"action_type": kind, "obs_format": "masked"})
FAMILIES["BoxPushing-v0/robots join and leave"] = (
    "BoxPushing-v0",
    {
        "situation": "S2",
        "n_spare_robots": 1,
        "events": ((3, "add_robot"), (6, "remove_robot", "robot_0"), (8, "break_down", "robot_1")),
    },
)
FAMILIES["Foraging-v0/surround"] = ("Foraging-v0", {"task": "surround", "n_robots": 3})
FAMILIES["Exploration-v0/doors resampled"] = ("Exploration-v0", {"action_type": "operator", "door_resample_period": 2})


def _make(env_id: str, config: dict):
    return teamgym.make(env_id, max_cycles=120, **config)


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_info_keys_never_change_within_or_across_episodes(family):
    env_id, config = FAMILIES[family]
    env = _make(env_id, config)
    schema = env.info_schema()
    assert "success" in schema
    for seed in (0, 1):
        observations, infos = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for step in range(40):
            for agent, info in infos.items():
                assert list(info) == list(schema), f"{family} step {step} {agent}: {sorted(set(info) ^ set(schema))}"
                for key, value in info.items():
                    assert not isinstance(value, str), key
                    if schema[key].kind == "categorical":
                        assert isinstance(value, (int, np.integer)) and value >= -1, (key, value)
            for agent, observation in observations.items():
                assert env.observation_space(agent).contains(observation), (family, agent)
            if not env.agents:
                break
            actions = {a: _random_value(env.action_space(a), infos[a].get("action_mask"), rng, env) for a in env.agents}
            observations, _, _, _, infos = env.step(actions)


@pytest.mark.parametrize(("env_id", "config"), [FAMILIES[f] for f in sorted(FAMILIES) if "masked" in f or "dict" in f])
def test_observed_masks_equal_infos_and_action_masks(env_id, config):
    env = _make(env_id, config)
    observations, infos = env.reset(seed=4)
    rng = np.random.default_rng(4)
    fmt = config["obs_format"]
    for _ in range(15):
        masks = env.action_masks()
        for agent, observation in observations.items():
            field = "motion_mask" if config.get("comm_dim") else "action_mask"
            if field not in env.observation_space(agent).spaces:
                assert fmt == "dict" and not masks
                continue
            observed = observation[field]
            assert observed.dtype == np.int8
            info_mask = infos[agent].get("action_mask")
            if info_mask is not None:
                np.testing.assert_array_equal(observed, info_mask if isinstance(info_mask, np.ndarray) else info_mask["motion"])
                if agent in env.agents:
                    np.testing.assert_array_equal(observed, masks[agent])
            else:
                assert observed.all()  # a discrete action type without masks: everything admissible
            if fmt == "masked":
                assert observation["observation"].shape == (env.layout.size,)
        if not env.agents:
            break
        actions = {a: _random_value(env.action_space(a), infos[a].get("action_mask"), rng, env) for a in env.agents}
        observations, _, _, _, infos = env.step(actions)


def test_masked_format_is_refused_for_continuous_actions():
    with pytest.raises(teamgym.ConfigError, match="obs_format='masked' needs a discrete action space"):
        teamgym.make("Navigation-v0", obs_format="masked")


def test_unknown_values_are_minus_one_until_known():
    env = teamgym.make("Navigation-v0", n_obstacles=0, min_goal_distance=0.1)
    _, infos = env.reset(seed=0)
    assert all(info["time_to_goal"] == -1.0 for info in infos.values())
    env = teamgym.make("Foraging-v0")
    _, infos = env.reset(seed=0)
    assert all(infos["robot_0"][key] == -1.0 for key in ("TL", "TT1", "TT2", "TT3", "TG"))
    assert env.info_schema()["TL"].sentinel and not env.info_schema()["DG"].sentinel


@pytest.mark.parametrize(
    ("env_id", "policy", "config", "categorical"),
    [
        (
            "Exploration-v0",
            "nash-explore",
            {"action_type": "operator"},
            ("sector", "place", "task", "task_status", "task_reason"),
        ),
        ("Rendezvous-v0", "bidir-astar", {}, ("place",)),
    ],
)
def test_summaries_never_average_categorical_infos(env_id, policy, config, categorical, tmp_path):
    results = evaluate(env_id, policy, episodes=1, config=config)
    summary = summarise(results)
    for key in categorical:
        assert key in results[0].metrics["robot_0"]  # kept per robot (experiments name places and sectors)
        assert f"mean_{key}" not in summary and key not in summary["metrics"]
    assert "mean_path_length" in summary
    header = write_episodes_csv(tmp_path / "episodes.csv", results).read_text().splitlines()[0].split(",")
    assert not set(categorical) & set(header)
