"""The Rendezvous preset ``rendezvous-comm-maskable-ppo``: learned messages and a central critic; short runs only."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("sb3_contrib")

import teamgym  # noqa: E402
from baselines.rl import presets as presets_module  # noqa: E402
from baselines.rl.presets import load_preset, presets  # noqa: E402
from baselines.rl.train import _plan, build_parser  # noqa: E402
from baselines.rl.train import main as train_main  # noqa: E402

NAME = "rendezvous-comm-maskable-ppo"


def plan(*args: str) -> dict:
    return _plan(build_parser().parse_args(list(args)))[0]


def test_preset_builds_the_aims_task_with_a_learned_message():
    assert NAME in presets()
    preset = load_preset(NAME)
    assert preset.env == "Rendezvous-v0" and preset.algo == "maskable_ppo"
    assert preset.message_actions == {"levels": 9} and preset.critic == "central"
    env = teamgym.make(preset.env, **preset.config)
    try:
        env.reset(seed=0)
        c = env.config
        assert (c.map, c.block_rate, c.comm_throughput, c.comm_dim) == ("paper003_fig5", 0.096, 0.5, 2)
        assert {"inbox", "inbox_mask", "neighbour_xy"} <= set(env.layout.shapes)
    finally:
        env.close()
    for key in (*preset.config, "message_actions", "critic"):
        assert any(key in documented for documented in preset.changes), f"{key} is not explained"


def test_preset_plans_its_message_levels_and_critic_and_the_command_line_wins():
    kwargs = plan("--preset", NAME, "--out", "m.zip")
    assert kwargs["message_levels"] == 9 and kwargs["critic"] == "central"
    assert plan("--preset", NAME, "--message-levels", "5", "--out", "m.zip")["message_levels"] == 5
    assert "message_levels" not in plan("--preset", "exploration-maskable-ppo", "--out", "m.zip")


def test_bad_message_actions_in_a_preset_are_one_line_errors(tmp_path, monkeypatch, capsys):
    data = json.loads((presets_module.PRESET_DIR / f"{NAME}.json").read_text())
    data["message_actions"] = {"levles": 9}
    (tmp_path / "bad.json").write_text(json.dumps(data))
    monkeypatch.setattr(presets_module, "PRESET_DIR", tmp_path)
    with pytest.raises(ValueError, match="message_actions must be an object of levels, tokens, vocab"):
        load_preset("bad")
    assert train_main(["--preset", "bad", "--timesteps", "64", "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert "message_actions" in err and len(err.strip().splitlines()) == 1


def test_preset_trains_end_to_end_and_its_messages_go_through_the_channel(tmp_path):
    from baselines.evaluate import main as evaluate_main

    out = tmp_path / "m.zip"
    args = ["--preset", NAME, "--timesteps", "64", "--n-envs", "1", "--verbose", "0", "--set", "max_cycles=300"]
    args += ["--hp", "n_steps=32", "--hp", "batch_size=64", "--eval-every", "0", "--out", str(out)]
    assert train_main(args) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["preset"] == NAME and sidecar["critic"] == "central"
    assert sidecar["message_actions"]["kind"] == "learned" and sidecar["message_actions"]["levels"] == 9
    summaries = {}
    for throughput in ("0.5", "0"):
        where = tmp_path / f"ev{throughput}"
        command = ["--policy", f"sb3:{out}", "--episodes", "2", "--seed", "31000", "--quiet", "--no-plot"]
        assert evaluate_main([*command, "--set", f"comm_throughput={throughput}", "--out", str(where)]) == 0
        summaries[throughput] = json.loads((where / "summary.json").read_text())
    assert summaries["0.5"]["mean_bytes_sent"] > 0 and summaries["0.5"]["mean_messages_delivered"] > 0
    assert summaries["0"]["mean_messages_delivered"] == 0  # the channel cut: nothing arrives


def test_shipped_agent_plays_the_aims_task_with_its_messages_and_with_the_channel_cut():
    from baselines.episode import run_episode
    from baselines.registry import make_policy
    from baselines.rl.sb3_policy import read_sidecar, resolve_model, shipped_agents

    assert NAME in shipped_agents()
    sidecar = read_sidecar(resolve_model(NAME))
    assert sidecar["preset"] == NAME and sidecar["critic"] == "central"
    assert sidecar["message_actions"]["levels"] == 9
    for throughput in (0.5, 0.0):
        env = teamgym.make("Rendezvous-v0", **{**sidecar["config"], "max_cycles": 300, "comm_throughput": throughput})
        result = run_episode(env, make_policy(f"sb3:{NAME}", env), 31000, record_trajectories=False)
        assert set(result.returns) == set(env.possible_agents) and result.length >= 1
        delivered = sum(m["messages_delivered"] for m in result.metrics.values())
        assert (delivered > 0) == (throughput > 0)


BEACON = "rendezvous-beacon-dagger-recurrent-ppo"


def test_beacon_preset_builds_the_aims_task_with_three_message_values_and_place_beacon_as_teacher():
    preset = load_preset(BEACON)
    assert (preset.env, preset.algo, preset.message_actions) == ("Rendezvous-v0", "maskable_recurrent_ppo", {"levels": 9})
    assert preset.bc["expert"] == "place-beacon" and preset.bc["noise"] == 0.0 and preset.bc["dagger_rounds"] == 4
    env = teamgym.make(preset.env, **preset.config)
    try:
        c = env.config
        assert (c.block_rate, c.comm_throughput, c.comm_dim, c.max_cycles) == (0.096, 0.5, 3, 6000)
    finally:
        env.close()
    for key in (*preset.config, "message_actions", "algo", "bc", "policy_kwargs"):
        assert any(key in documented for documented in preset.changes), f"{key} is not explained"


def test_beacon_preset_clones_and_trains_end_to_end_with_the_messages_in_the_channel(tmp_path):
    from baselines.evaluate import main as evaluate_main

    out = tmp_path / "m.zip"
    args = ["--preset", BEACON, "--timesteps", "64", "--n-envs", "1", "--verbose", "0", "--set", "max_cycles=300"]
    args += ["--hp", "n_steps=32", "--hp", "batch_size=64", "--hp", 'policy_kwargs={"lstm_hidden_size": 16, "net_arch": [16]}']
    args += ["--bc-expert", "place-beacon", "--bc-steps", "200", "--bc-epochs", "2", "--bc-dagger", "1"]
    args += ["--bc-dagger-steps", "60", "--bc-dagger-epochs", "1"]
    args += ["--eval-every", "0", "--out", str(out)]
    assert train_main(args) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["preset"] == BEACON and sidecar["bc"]["expert"] == "place-beacon"
    assert sidecar["bc"]["dagger_transitions"] == 260 and sidecar["message_actions"]["levels"] == 9
    where = tmp_path / "ev"
    command = ["--policy", f"sb3:{out}", "--episodes", "2", "--seed", "31000", "--quiet", "--no-plot", "--out", str(where)]
    assert evaluate_main(command) == 0
    summary = json.loads((where / "summary.json").read_text())
    assert summary["mean_bytes_sent"] > 0 and summary["mean_messages_delivered"] > 0


def test_shipped_beacon_agent_meets_through_the_channel():
    from baselines.episode import run_episode
    from baselines.registry import make_policy
    from baselines.rl.sb3_policy import read_sidecar, resolve_model, shipped_agents

    assert BEACON in shipped_agents()
    sidecar = read_sidecar(resolve_model(BEACON))
    assert sidecar["preset"] == BEACON and sidecar["bc"]["expert"] == "place-beacon"
    env = teamgym.make("Rendezvous-v0", **sidecar["config"])
    policy = make_policy(f"sb3:{BEACON}", env)
    results = [run_episode(env, policy, seed, record_trajectories=False) for seed in (31001, 31002)]
    assert all(result.success for result in results)  # both met (100 % and 99 % of 31000-31099 for the shipped seed)
    assert all(sum(m["messages_delivered"] for m in result.metrics.values()) > 0 for result in results)
