"""``compare`` on every env with its paper's baseline and own metrics; ``train`` and masks (issue 25, deliverable 5)."""

import json

import pytest

import teamgym
from baselines.rl.compare import OWN_METRICS, SCRIPTED, main
from baselines.rl.sb3_policy import algorithm_name, check_masks


def test_every_env_lists_its_papers_baseline_first():
    assert set(SCRIPTED) == set(teamgym.envs()) == set(OWN_METRICS)
    assert SCRIPTED["Foraging-v0"][0][1] == "dmaps" and SCRIPTED["Rendezvous-v0"][0][1] == "bidir-astar"
    assert {"dmaps-nocomm", "random-walk"} <= {p for _, p in SCRIPTED["Foraging-v0"]}
    assert {"bidir-astar-opt", "centralized"} <= {p for _, p in SCRIPTED["Rendezvous-v0"]}


@pytest.mark.parametrize(
    ("env_id", "config", "own"),
    [
        ("Foraging-v0", ["--set", "time_limit=60"], ("TL", "TT1", "DG")),
        ("Rendezvous-v0", [], ("meeting_time", "replans", "bytes_sent")),
    ],
)
def test_compare_plays_the_papers_rows_with_their_metrics(env_id, config, own, tmp_path, capsys):
    assert main(["--env", env_id, "--episodes", "2", "--out", str(tmp_path), *config]) == 0
    record = json.loads((tmp_path / "comparison.json").read_text())
    rows = {row["policy"]: row for row in record["rows"]}
    assert set(rows) == {policy for _, policy in SCRIPTED[env_id]}
    paper = rows[SCRIPTED[env_id][0][1]]
    for name in own:
        assert paper["metrics"][name]["n"] >= 1, name
    table = (tmp_path / "comparison.md").read_text()
    assert all(f" {name} |" in table.splitlines()[0] for name in own)
    assert "note: no scripted baselines" not in capsys.readouterr().err


@pytest.mark.parametrize("spelling", ["maskable-ppo", "maskable_ppo", "MaskablePPO", " Maskable-PPO "])
def test_algorithm_names_take_the_hyphenated_spellings(spelling):
    assert algorithm_name(spelling) == "maskable_ppo"


def test_unknown_algorithm_is_refused_naming_it():
    with pytest.raises(ValueError, match="unknown SB3 algorithm 'bogus'"):
        algorithm_name("bogus")


@pytest.mark.parametrize(
    ("env_id", "config"), [("Rendezvous-v0", {}), ("Foraging-v0", {}), ("Exploration-v0", {"action_type": "operator"})]
)
def test_an_algorithm_that_ignores_masks_is_refused_on_a_masked_env(env_id, config):
    env = teamgym.make(env_id, **config)
    for algo in ("ppo", "a2c", "dqn"):
        with pytest.raises(ValueError, match="cannot respect the action masks.*use --algo maskable-ppo"):
            check_masks(algo, env)
    check_masks("maskable-ppo", env)
    check_masks("ppo", teamgym.make("Navigation-v0", action_type="heading"))  # no masks: any algorithm


def test_train_cli_refuses_ppo_on_rendezvous_before_any_work(tmp_path, capsys):
    from baselines.rl.train import main as train_main

    out = tmp_path / "model.zip"
    assert train_main(["--env", "Rendezvous-v0", "--algo", "ppo", "--timesteps", "64", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "maskable-ppo" in err[0] and "Traceback" not in err[0]
    assert not out.exists()
