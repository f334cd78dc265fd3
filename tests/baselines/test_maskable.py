"""sb3-contrib's ``MaskablePPO`` (``--algo maskable_ppo``) on Exploration-v0's operator actions."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

from sb3_contrib import MaskablePPO  # noqa: E402

import teamgym  # noqa: E402
from baselines.evaluate import main as evaluate_main  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy, algorithm_class, check_action_space, detect_algorithm  # noqa: E402
from baselines.rl.train import Training, train  # noqa: E402
from baselines.train import main as train_main  # noqa: E402
from teamgym.envs.batch import TeamBatch  # noqa: E402
from teamgym.envs.exploration import Exploration  # noqa: E402

ENV = "Exploration-v0"
CONFIG = {"action_type": "operator", "n_robots": 2, "max_cycles": 150}


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def count_masked(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Wrap ``Exploration.step`` and ``TeamBatch.step`` (the SB3 adapter steps a batch): count the operators
    given and those the masks forbid (before the env sees them)."""
    counts = {"actions": 0, "masked": 0}
    step, batch_step = Exploration.step, TeamBatch.step

    def checking_step(self: Exploration, actions: dict[str, Any]) -> Any:
        masks = self.action_masks()
        for agent, action in actions.items():
            counts["actions"] += 1
            counts["masked"] += int(not masks[agent][int(action)])
        return step(self, actions)

    def checking_batch_step(self: TeamBatch, actions: Any) -> Any:
        masks, active = self.action_masks(), self.active
        for k, i in zip(*np.nonzero(active)):
            counts["actions"] += 1
            counts["masked"] += int(not masks[k, i, int(actions[k, i])])
        return batch_step(self, actions)

    monkeypatch.setattr(Exploration, "step", checking_step)
    monkeypatch.setattr(TeamBatch, "step", checking_batch_step)
    return counts


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A MaskablePPO model trained a few hundred steps by ``baselines.rl.train.train`` (with its sidecar);
    no masked operator may reach the env while it trains."""
    out = tmp_path_factory.mktemp("maskable") / "m.zip"
    with pytest.MonkeyPatch.context() as monkeypatch:
        counts = count_masked(monkeypatch)
        hyperparameters = {"n_steps": 32, "batch_size": 64, "n_epochs": 2}
        path = train(ENV, "maskable_ppo", timesteps=300, out=out, config=CONFIG, n_envs=2, hyperparameters=hyperparameters)
    assert counts["actions"] >= 300 and counts["masked"] == 0, counts
    return path


def test_algorithm_class_is_sb3_contribs_maskable_ppo() -> None:
    assert algorithm_class("maskable_ppo") is MaskablePPO
    assert algorithm_class("MASKABLE_PPO") is MaskablePPO


def test_training_never_sends_a_masked_operator(trained: Path) -> None:
    meta = json.loads(trained.with_suffix(".json").read_text())
    assert meta["algo"] == "maskable_ppo" and meta["config"]["action_type"] == "operator"
    model = MaskablePPO.load(str(trained), device="cpu")
    assert model.num_timesteps >= 300


def test_detect_algorithm_from_sidecar_and_from_the_zip(trained: Path, tmp_path: Path) -> None:
    assert detect_algorithm(trained) == "maskable_ppo"
    bare = tmp_path / "bare.zip"  # no sidecar: the saved policy class tells
    shutil.copy(trained, bare)
    assert not bare.with_suffix(".json").exists()
    assert detect_algorithm(bare) == "maskable_ppo"
    policy = SB3Policy.load(bare, teamgym.make(ENV, **CONFIG))
    assert policy.algo == "maskable_ppo" and policy.maskable


def test_evaluate_cli_never_picks_a_masked_operator(trained: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    counts = count_masked(monkeypatch)
    out = tmp_path / "eval"
    argv = ["--policy", f"sb3:{trained}", "--episodes", "3", "--seed", "20000", "--out", str(out), "--no-plot", "--quiet"]
    assert evaluate_main(argv) == 0  # env and config from the sidecar
    summary = json.loads((out / "summary.json").read_text())
    assert summary["env"] == ENV and summary["episodes"] == 3
    assert counts["actions"] > 0 and counts["masked"] == 0, counts


@pytest.mark.parametrize("allowed", [0, 7])
def test_sb3_policy_passes_the_env_masks(trained: Path, allowed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    env = teamgym.make(ENV, **CONFIG)
    policy = SB3Policy.load(trained, env)
    observations, _ = env.reset(seed=3)
    n = env.action_space(env.agents[0]).n
    only = np.zeros(n, dtype=np.int8)
    only[allowed] = 1
    monkeypatch.setattr(env, "action_masks", lambda: {a: only for a in env.agents})
    for deterministic in (True, False):
        policy.deterministic = deterministic
        assert policy.act(observations) == {a: allowed for a in env.agents}


def test_maskable_ppo_refuses_a_box_action_space(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    env = teamgym.make(ENV)  # action_type="velocity": (v, ω)
    box = env.action_space(env.possible_agents[0])
    assert isinstance(box, spaces.Box)
    with pytest.raises(ValueError, match=r"maskable_ppo needs Discrete, MultiDiscrete or MultiBinary actions.*Box"):
        check_action_space("maskable_ppo", box)
    check_action_space("maskable_ppo", spaces.Discrete(3))
    check_action_space("ppo", box)
    with pytest.raises(ValueError, match="action_type=operator"):
        Training(ENV, "maskable_ppo", timesteps=10, out=tmp_path / "m.zip", n_envs=1)
    assert train_main(["--env", ENV, "--algo", "maskable_ppo", "--timesteps", "10", "--out", str(tmp_path / "m.zip")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: maskable_ppo needs Discrete") and err.count("\n") == 1
    assert not (tmp_path / "m.zip").exists()
