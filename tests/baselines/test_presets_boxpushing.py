"""The BoxPushing RL presets ``boxpushing-s1-ppo`` and ``boxpushing-s1-stall-ppo`` and their shipped agents (no training here)."""

from __future__ import annotations

import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.rl.presets import load_preset, presets  # noqa: E402
from baselines.rl.sb3_policy import read_sidecar, resolve_model, shipped_agents  # noqa: E402
from baselines.rl.train import _plan, build_parser  # noqa: E402

NAME = "boxpushing-s1-ppo"
STALL = "boxpushing-s1-stall-ppo"


def test_preset_loads_and_its_config_builds_the_s1_env():
    assert NAME in presets()
    preset = load_preset(NAME)
    assert preset.env == "BoxPushing-v0" and preset.algo == "ppo"
    env = teamgym.make(preset.env, **preset.config)
    try:
        env.reset(seed=0)
        assert env.possible_agents == ["robot_0"]  # S1: one robot
        assert env.config.n_light_boxes == 1 and env.config.n_heavy_boxes == 0
        assert env.action_space("robot_0").n == 13  # the paper's primitives
    finally:
        env.close()
    for key in preset.config:
        assert any(key in documented for documented in preset.changes), f"{key} is not explained"
    kwargs = _plan(build_parser().parse_args(["--preset", NAME, "--out", "m.zip"]))[0]
    assert kwargs["env_id"] == "BoxPushing-v0" and kwargs["timesteps"] == preset.timesteps
    assert kwargs["bc_expert"] == preset.bc["expert"] == "sbs"
    # The teacher is sbs without its looks (no free-standing stop labels) on clean data.
    assert kwargs["bc_expert_kwargs"] == preset.bc["expert_kwargs"] == {"look_cycles": 0}
    assert kwargs["bc_noise"] == preset.bc["noise"] == 0
    other = _plan(build_parser().parse_args(["--preset", NAME, "--bc-expert", "cooperative-push", "--out", "m.zip"]))[0]
    assert other["bc_expert"] == "cooperative-push" and "bc_expert_kwargs" not in other


def test_stall_preset_is_the_s1_preset_plus_the_stall_field():
    base, stall = load_preset(NAME), load_preset(STALL)
    assert stall.config == {**base.config, "observe_stall": True}
    assert (stall.bc, stall.hyperparameters, stall.timesteps, stall.n_envs) == (
        base.bc,
        base.hyperparameters,
        base.timesteps,
        base.n_envs,
    )
    assert "observe_stall" in stall.changes
    env = teamgym.make(stall.env, **stall.config)
    assert env.layout.fields[-1].name == "stall"


@pytest.mark.parametrize("name", [NAME, STALL])
def test_shipped_agent_resolves_and_acts_in_the_env(name):
    from baselines.episode import run_episode
    from baselines.registry import make_policy

    if name not in shipped_agents():
        pytest.skip("agent not shipped")
    path = resolve_model(name)
    sidecar = read_sidecar(path)
    assert sidecar["env"] == "BoxPushing-v0" and sidecar["preset"] == name
    env = teamgym.make("BoxPushing-v0", **{**sidecar["config"], "max_cycles": 20})
    assert env.config.observe_stall == (name == STALL)
    policy = make_policy(f"sb3:{name}", env)
    result = run_episode(env, policy, 20000, record_trajectories=False)
    assert result.length == 20 and set(result.returns) == {"robot_0"}
    obs, _ = env.reset(seed=1)
    actions = policy.act(obs)
    assert env.action_space("robot_0").contains(actions["robot_0"])
