"""``baselines.learned``: the ``sb3:``/``rllib:`` schemes and the one sidecar format of both engines."""

import json
from pathlib import Path

import pytest

from baselines import evaluate as evaluate_module
from baselines.learned import (
    SIDECAR_FORMAT,
    check_sidecar,
    policy_sidecar,
    read_sidecar,
    split_scheme,
    write_sidecar,
)
from baselines.registry import policy_class
from tests.rllib_support import HAVE_RAY

AGENTS = Path(__file__).resolve().parents[2] / "baselines" / "rl" / "agents"

#: A sidecar as ``python -m baselines.rl.rllib`` wrote it before format 1: the given settings in ``config``.
OLD_RLLIB = {
    "env": "Foraging-v0",
    "config": {"max_cycles": "40", "n_robots": 2},
    "algo": "ppo",
    "module_id": "shared",
    "seed": 0,
    "iterations": 1,
    "history": [{"iteration": 1, "env_steps": 200.0}],
}


def _core(sidecar: dict) -> tuple:
    return sidecar["format"], sidecar["engine"], sidecar["env"], sidecar["overrides"], sidecar["algo"], sidecar["seed"]


@pytest.mark.parametrize("name", sorted(p.stem for p in AGENTS.glob("*.zip")))
def test_a_shipped_agents_old_sidecar_and_its_rewrite_read_the_same(name, tmp_path):
    old = json.loads((AGENTS / f"{name}.json").read_text())
    read = read_sidecar("sb3", name)
    if "format" in old:  # written in format 1 (boxpushing-s3-ppo): read as it is
        assert old["format"] == SIDECAR_FORMAT and old["engine"] == "sb3" and read == old
    else:  # written before format 1
        assert "engine" not in old and read == {"format": SIDECAR_FORMAT, "engine": "sb3", **old}
    (tmp_path / f"{name}.zip").write_bytes(b"not read")
    write_sidecar(tmp_path / f"{name}.json", "sb3", read)
    assert read_sidecar("sb3", tmp_path / f"{name}.zip") == read
    assert list(json.loads((tmp_path / f"{name}.json").read_text()))[:5] == ["format", "engine", "env", "overrides", "config"]


def test_an_old_rllib_sidecar_reads_as_the_new_one(tmp_path):
    old_dir, new_dir = tmp_path / "old", tmp_path / "new"
    old_dir.mkdir()
    (old_dir / "teamgym.json").write_text(json.dumps(OLD_RLLIB))
    old = read_sidecar("rllib", old_dir)
    assert old["overrides"] == {"max_cycles": "40", "n_robots": "2"} and "config" not in old
    resolved = {"max_cycles": 40, "n_robots": 2, "dt": 0.1}
    new = {**{k: v for k, v in OLD_RLLIB.items() if k != "config"}, "overrides": {"max_cycles": "40", "n_robots": "2"}}
    write_sidecar(new_dir / "teamgym.json", "rllib", {**new, "config": resolved})
    again = read_sidecar("rllib", new_dir)
    assert _core(again) == _core(old) == (1, "rllib", "Foraging-v0", {"max_cycles": "40", "n_robots": "2"}, "ppo", 0)
    assert again["config"] == resolved and again["history"] == old["history"]
    assert policy_sidecar(f"rllib:{old_dir}") == (old, old_dir / "teamgym.json")


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"env": 3}, "'env' must be a non-empty string"),
        ({"overrides": ["max_cycles=5"]}, "'overrides' must be an object"),
        ({"overrides": {"max_cycles": [5]}}, "'overrides.max_cycles' must be a string"),
        ({"format": 2}, "'format' must be 1"),
        ({"engine": "rllib"}, "'engine' must be 'sb3'"),
        ({"algo": ""}, "'algo' must be a non-empty string"),
    ],
)
def test_a_bad_sidecar_is_one_line_naming_the_file_and_the_field(change, field, tmp_path, capsys):
    (tmp_path / "m.zip").write_bytes(b"not read")
    sidecar = tmp_path / "m.json"
    sidecar.write_text(json.dumps({"env": "Navigation-v0", "overrides": {}, "algo": "ppo", **change}))
    with pytest.raises(ValueError, match=field) as raised:
        read_sidecar("sb3", tmp_path / "m.zip")
    assert str(sidecar) in str(raised.value) and "\n" not in str(raised.value)
    assert evaluate_module.main(["--policy", f"sb3:{tmp_path / 'm.zip'}", "--out", str(tmp_path / "out"), "--quiet"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("error: ") and str(sidecar) in line and field in line
    assert not (tmp_path / "out").exists()


def test_writing_checks_the_fields_first(tmp_path):
    with pytest.raises(ValueError, match="'env' must be a non-empty string"):
        write_sidecar(tmp_path / "m.json", "sb3", {"env": "", "overrides": {}})
    assert not (tmp_path / "m.json").exists()
    with pytest.raises(ValueError, match="is not a JSON object"):
        check_sidecar([1, 2], "sb3", tmp_path / "m.json")


def test_one_scheme_per_engine():
    from baselines.rl.rllib import RLlibPolicy
    from baselines.rl.sb3_policy import SB3Policy

    assert split_scheme("sb3:a/b.zip") == ("sb3", "a/b.zip") and split_scheme("rllib:ckpt") == ("rllib", "ckpt")
    assert split_scheme("goto") is None and split_scheme("other:x") is None
    assert policy_class("sb3:a.zip") is SB3Policy and policy_class("rllib:ckpt") is RLlibPolicy
    assert evaluate_module._slug("rllib:results/rllib/Navigation-v0_ppo") == "rllib-Navigation-v0_ppo"


def test_an_rllib_checkpoint_gives_the_evaluation_its_env_and_config(tmp_path, capsys):
    (tmp_path / "teamgym.json").write_text(json.dumps(OLD_RLLIB))
    env, config, path, trained_on = evaluate_module._model_defaults(f"rllib:{tmp_path}", None, {"max_cycles": "60"})
    assert (env, trained_on, path) == ("Foraging-v0", "Foraging-v0", tmp_path / "teamgym.json")
    assert config == {"max_cycles": "60", "n_robots": "2"}  # an explicit setting wins, key by key
    assert evaluate_module.main(["--policy", "rllib:", "--quiet"]) == 2
    assert "expected an RLlib checkpoint directory after rllib:" in capsys.readouterr().err


@pytest.mark.skipif(HAVE_RAY, reason="checks the error when ray is missing")
def test_an_rllib_policy_without_ray_is_one_line_before_any_episode(tmp_path, capsys):
    (tmp_path / "teamgym.json").write_text(json.dumps(OLD_RLLIB))
    assert evaluate_module.main(["--policy", f"rllib:{tmp_path}", "--out", str(tmp_path / "out"), "--quiet"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("error: the RLlib path needs the ray package") and not (tmp_path / "out").exists()


def test_compare_plays_an_rllib_checkpoint_on_its_sidecars_overrides(tmp_path, monkeypatch):
    from baselines.episode import EpisodeResult
    from baselines.rl.compare import compare

    (tmp_path / "module_state.pkl").write_bytes(b"not read")  # what module_path looks for
    (tmp_path / "teamgym.json").write_text(json.dumps(OLD_RLLIB))
    seen = {}

    def spy(env_id, policy, episodes, seed, config, workers):
        seen[policy] = dict(config)
        return [EpisodeResult(seed, 5, False, {"robot_0": 0.0}, {"robot_0": {}})]

    monkeypatch.setattr(evaluate_module, "evaluate", spy)
    rows = compare("Foraging-v0", f"rllib:{tmp_path}", episodes=1, task={"max_cycles": 30}, policies=[])
    assert seen == {f"rllib:{tmp_path}": {"max_cycles": 30, "n_robots": "2"}}  # --set wins over the sidecar
    assert [row["label"] for row in rows] == [f"trained: rllib:{tmp_path}"]
    with pytest.raises(ValueError, match="was trained on Foraging-v0, not Navigation-v0"):
        compare("Navigation-v0", f"rllib:{tmp_path}", episodes=1, policies=[])
    with pytest.raises(FileNotFoundError, match="no RLlib checkpoint"):
        compare("Foraging-v0", f"rllib:{tmp_path / 'none'}", episodes=1, policies=[])
