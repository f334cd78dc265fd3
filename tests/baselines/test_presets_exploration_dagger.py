"""The Exploration preset ``exploration-nash-dagger-ppo`` (a MaskablePPO clone of nash-explore) and its shipped agent."""

from __future__ import annotations

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import teamgym  # noqa: E402
from baselines.rl.presets import load_preset, presets  # noqa: E402
from baselines.rl.train import _plan, build_parser  # noqa: E402

NAME = "exploration-nash-dagger-ppo"


def plan(*args: str) -> dict:
    return _plan(build_parser().parse_args(list(args)))[0]


def test_preset_plans_a_maskable_clone_of_nash_explore_with_dagger():
    assert NAME in presets()
    preset = load_preset(NAME)
    assert preset.env == "Exploration-v0" and preset.algo == "maskable_ppo"
    env = teamgym.make(preset.env, **preset.config)
    try:
        assert env.config.action_type == "operator" and env.config.map == "office12" and env.config.n_robots == 3
        assert env.config.max_cycles == 3000  # the task judged: the defaults except the reward weight
    finally:
        env.close()
    for key in (*preset.config, "bc"):
        assert any(key in documented for documented in preset.changes), f"{key} is not explained"
    kwargs = plan("--preset", NAME, "--out", "m.zip")
    bc = preset.bc
    assert (kwargs["bc_expert"], kwargs["bc_steps"], kwargs["bc_noise"]) == ("nash-explore", bc["steps"], 0.0)
    assert (kwargs["bc_dagger"], kwargs["bc_dagger_steps"], kwargs["bc_dagger_epochs"]) == (
        bc["dagger_rounds"],
        bc["dagger_steps"],
        bc["dagger_epochs"],
    )
    assert kwargs["algo"] == "maskable_ppo" and kwargs["timesteps"] == preset.timesteps


def test_shipped_agent_is_the_median_seed_and_plays_its_env_from_its_sidecar():
    from baselines.episode import run_episode
    from baselines.registry import make_policy
    from baselines.rl.sb3_policy import read_sidecar, resolve_model, shipped_agents

    assert NAME in shipped_agents()
    sidecar = read_sidecar(resolve_model(NAME))
    assert sidecar["preset"] == NAME and sidecar["algo"] == "maskable_ppo" and sidecar["bc"]["expert"] == "nash-explore"
    seeds = sidecar["seeds"]
    assert seeds["seeds"] == [0, 1, 2] and seeds["median_seed"] in seeds["seeds"] and sidecar["seed"] == seeds["median_seed"]
    env = teamgym.make(sidecar["env"], **{**sidecar["config"], "max_cycles": 15})
    result = run_episode(env, make_policy(f"sb3:{NAME}", env), 31000, record_trajectories=False)
    assert set(result.returns) == set(env.possible_agents) and 1 <= result.length <= 15
