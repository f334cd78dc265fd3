"""RL presets (``--preset``), worker processes (``--workers``) and the padding share in the sidecar."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("stable_baselines3")

from baselines.rl.presets import load_preset, presets  # noqa: E402
from baselines.rl.train import _plan, build_parser  # noqa: E402
from baselines.rl.train import main as train_main  # noqa: E402


def plan(*args: str) -> dict:
    return _plan(build_parser().parse_args(list(args)))[0]


def test_every_shipped_preset_loads_and_builds_its_env():
    import teamgym

    assert "navigation-ppo" in presets()
    for name in presets():
        preset = load_preset(name)
        teamgym.make(preset.env, **preset.config).close()  # a valid config of its env
        assert preset.changes, f"{name}: document what the preset changes"
        for key in preset.config:
            assert any(key in documented for documented in preset.changes), f"{name}: {key} is not explained"


def test_preset_values_and_command_line_overrides():
    preset = load_preset("navigation-ppo")
    kwargs = plan("--preset", "navigation-ppo", "--out", "m.zip")
    assert kwargs["env_id"] == preset.env and kwargs["algo"] == preset.algo and kwargs["n_envs"] == preset.n_envs
    assert kwargs["timesteps"] == preset.timesteps and kwargs["preset"] == "navigation-ppo"
    assert kwargs["hyperparameters"] == preset.hyperparameters
    assert set(kwargs["config"]) == set(preset.config)
    assert kwargs["bc_expert"] == preset.bc["expert"] and kwargs["eval_every"] == preset.eval["every"]
    mine = plan(
        "--preset", "navigation-ppo", "--timesteps", "64", "--set", "collision_penalty=2", "--hp", "n_epochs=3", "--n-envs", "2"
    )
    assert mine["timesteps"] == 64 and mine["n_envs"] == 2
    assert mine["config"]["collision_penalty"] == "2" and mine["hyperparameters"]["n_epochs"] == 3
    other = plan("--preset", "navigation-ppo", "--bc-expert", "nash", "--set", "action_type=heading")
    assert other["bc_expert"] == "nash" and other["bc_steps"] == preset.bc["steps"] and other["bc_epochs"] == preset.bc["epochs"]
    assert plan("--preset", "navigation-ppo", "--bc-expert", "goto", "--bc-steps", "7")["bc_steps"] == 7
    assert plan("--bc-expert", "goto", "--bc-dagger", "2")["bc_dagger"] == 2
    assert plan("--bc-expert", "goto")["bc_dagger"] == 0


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--preset", "no-such-preset"], "unknown preset 'no-such-preset'; available: "),
        (["--bc-dagger", "2"], "--bc-dagger needs --bc-expert"),
        (["--bc-expert", "goto", "--bc-dagger", "-1"], "--bc-dagger must be >= 0"),
        (["--preset", "navigation-ppo", "--env", "Exploration-v0"], "is for Navigation-v0, not Exploration-v0"),
        (["--preset", "navigation-ppo", "--resume", "m.zip"], "--preset starts a new run"),
        (["--workers", "3", "--n-envs", "2"], "workers must be in [1, n_envs=2]"),
    ],
)
def test_preset_and_worker_errors_are_one_line(args, needle, tmp_path, capsys):
    assert train_main([*args, "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
    assert not (tmp_path / "m.zip").exists()


def test_training_in_worker_processes_records_workers_and_padding(tmp_path):
    out = tmp_path / "w.zip"
    args = ["--env", "Navigation-v0", "--set", "n_robots=2", "--max-cycles", "10", "--n-envs", "2", "--workers", "2"]
    args += ["--timesteps", "128", "--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=1", "--verbose", "0"]
    assert train_main([*args, "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["workers"] == 2 and sidecar["trained_timesteps"] >= 128
    assert 0.0 <= sidecar["padding_share"] < 1.0


@pytest.mark.parametrize(
    "name",
    [
        "navigation-ppo",
        "navigation-dagger-ppo",
        "navigation-forces-dagger-ppo",
        "exploration-maskable-ppo",
        "rendezvous-comm-maskable-ppo",
        "rendezvous-beacon-dagger-recurrent-ppo",
        "exploration-nash-dagger-ppo",
        "foraging-dagger-maskable-ppo",
        "foraging-cells-dagger-maskable-ppo",
    ],
)
def test_shipped_agent_plays_its_env_from_its_sidecar(name):
    import teamgym
    from baselines.episode import run_episode
    from baselines.registry import make_policy
    from baselines.rl.sb3_policy import read_sidecar, resolve_model, shipped_agents

    assert name in shipped_agents()
    sidecar = read_sidecar(resolve_model(name))
    assert sidecar["preset"] == name and name in presets()
    env = teamgym.make(sidecar["env"], **{**sidecar["config"], "max_cycles": 15})
    result = run_episode(env, make_policy(f"sb3:{name}", env), 20000, record_trajectories=False)
    assert set(result.returns) == set(env.possible_agents) and 1 <= result.length <= 15


def test_foraging_preset_clones_dmaps_from_its_own_episodes_into_maskable_ppo():
    kwargs = plan("--preset", "foraging-dagger-maskable-ppo")
    preset = load_preset("foraging-dagger-maskable-ppo")
    assert kwargs["algo"] == "maskable_ppo" and preset.config == {"observe_world_model": True, "observe_novelty": True}
    assert (kwargs["bc_expert"], kwargs["bc_noise"], kwargs["bc_dagger"]) == ("dmaps", 0.0, preset.bc["dagger_rounds"])


def test_foraging_nohold_preset_changes_only_the_teacher():
    base, nohold = load_preset("foraging-dagger-maskable-ppo"), load_preset("foraging-nohold-dagger-maskable-ppo")
    for key in ("env", "algo", "config", "n_envs", "timesteps", "hyperparameters", "eval"):
        assert getattr(nohold, key) == getattr(base, key), key
    assert {k: v for k, v in nohold.bc.items() if k != "expert_kwargs"} == base.bc and "expert_kwargs" not in base.bc
    kwargs = plan("--preset", "foraging-nohold-dagger-maskable-ppo")
    assert kwargs["bc_expert_kwargs"] == {"params": {"min_hold": 0.0, "max_hold": 0.0}}
    assert plan("--preset", "foraging-dagger-maskable-ppo").get("bc_expert_kwargs") is None


def test_foraging_cells_preset_changes_the_network_and_the_dagger_rounds_only():
    nohold, cells = load_preset("foraging-nohold-dagger-maskable-ppo"), load_preset("foraging-cells-dagger-maskable-ppo")
    for key in ("env", "algo", "config", "n_envs", "timesteps", "eval"):
        assert getattr(cells, key) == getattr(nohold, key), key
    assert cells.hyperparameters == {k: v for k, v in nohold.hyperparameters.items() if k != "policy_kwargs"}
    assert {**cells.bc, "dagger_rounds": nohold.bc["dagger_rounds"]} == nohold.bc and cells.bc["dagger_rounds"] == 3
    kwargs = plan("--preset", "foraging-cells-dagger-maskable-ppo")
    assert kwargs["net"] == "cells" and "net" not in plan("--preset", "foraging-nohold-dagger-maskable-ppo")
    assert plan("--preset", "foraging-cells-dagger-maskable-ppo", "--net", "mlp")["net"] == "mlp"


def test_foraging8_preset_is_the_cell_recipe_at_8_robots_with_the_nocomm_teacher():
    cells, eight = load_preset("foraging-cells-dagger-maskable-ppo"), load_preset("foraging8-cells-nocomm-dagger-maskable-ppo")
    assert eight.config == {**cells.config, "n_robots": 8, "world_model_sources": "own"}
    assert (eight.env, eight.algo, eight.net, eight.hyperparameters) == (cells.env, cells.algo, cells.net, cells.hyperparameters)
    assert eight.bc["expert"] == "dmaps-nocomm" and eight.bc["expert_kwargs"] == cells.bc["expert_kwargs"]
    kwargs = plan("--preset", "foraging8-cells-nocomm-dagger-maskable-ppo")
    assert kwargs["config"]["n_robots"] == "8" and kwargs["bc_expert"] == "dmaps-nocomm" and kwargs["net"] == "cells"
    assert (kwargs["bc_steps"], kwargs["bc_dagger"], kwargs["bc_dagger_steps"]) == (40_000, 4, 16_000)
    assert plan("--preset", "foraging8-cells-nocomm-dagger-maskable-ppo", "--set", "n_robots=4")["config"]["n_robots"] == "4"


def test_shipped_cell_agent_records_its_network():
    from sb3_contrib import MaskablePPO

    from baselines.rl.cell_policy import MaskableCellPolicy
    from baselines.rl.sb3_policy import read_sidecar, resolve_model

    path = resolve_model("foraging-cells-dagger-maskable-ppo")
    assert read_sidecar(path)["net"] == "cells"
    assert type(MaskablePPO.load(path, device="cpu").policy) is MaskableCellPolicy


def test_dagger_preset_plans_its_imitation():
    kwargs = plan("--preset", "navigation-dagger-ppo")
    bc = load_preset("navigation-dagger-ppo").bc
    assert (kwargs["bc_expert"], kwargs["bc_steps"], kwargs["bc_noise"], kwargs["bc_batch_size"]) == ("nash", 100_000, 0.3, 1024)
    assert (kwargs["bc_dagger"], kwargs["bc_dagger_steps"], kwargs["bc_dagger_epochs"]) == (
        bc["dagger_rounds"],
        bc["dagger_steps"],
        bc["dagger_epochs"],
    )
