"""Expert constructor arguments for behaviour cloning (``pretrain(expert_kwargs=...)``, a preset's ``bc.expert_kwargs``).

The ``boxpushing-s1-ppo`` teacher is ``sbs`` with ``look_cycles=0``: it never labels a
free-standing ``stop`` (a look), while the default ``sbs`` does.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.rl.imitation import collect_expert_data, pretrain  # noqa: E402
from baselines.rl.train import train  # noqa: E402
from teamgym.control.primitives import Primitive  # noqa: E402

S1 = {"situation": "S1", "action_type": "primitives", "max_cycles": 400}


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def free_stops(look_cycles: int | None) -> int:
    """``stop`` labels of ``sbs`` outside multi-cycle primitives in 1200 S1 transitions."""
    kwargs = {} if look_cycles is None else {"look_cycles": look_cycles}
    data = collect_expert_data(teamgym.make("BoxPushing-v0", **S1), "sbs", 1200, seed=3, **kwargs)
    free = data.observations[:, -1] < 0.5  # the last field is ``busy``
    return int(np.sum(data.actions[free] == int(Primitive.STOP)))


def test_sbs_without_looks_labels_no_free_stop():
    assert free_stops(None) > 0  # the default sbs stops to look
    assert free_stops(0) == 0


def test_pretrain_passes_the_expert_arguments_and_records_them(tmp_path):
    out = tmp_path / "m.zip"
    hp = {"n_steps": 32, "batch_size": 32, "n_epochs": 1}
    config = {**S1, "max_cycles": 20}
    train(
        "BoxPushing-v0",
        "ppo",
        32,
        out=out,
        config=config,
        n_envs=1,
        hyperparameters=hp,
        bc_expert="sbs",
        bc_steps=40,
        bc_epochs=1,
        bc_dagger=1,
        bc_dagger_steps=20,
        bc_expert_kwargs={"look_cycles": 0},
    )
    record = json.loads(out.with_suffix(".json").read_text())["bc"]
    assert record["expert_kwargs"] == {"look_cycles": 0} and record["dagger_transitions"] == 60


def test_unknown_expert_argument_is_refused_before_any_work(tmp_path):
    with pytest.raises(TypeError, match="unknown recognizer parameter"):
        train("BoxPushing-v0", "ppo", 32, out=tmp_path / "m.zip", config=S1, bc_expert="sbs", bc_expert_kwargs={"nope": 1})
    with pytest.raises(ValueError, match="expert_kwargs"):
        train("BoxPushing-v0", "ppo", 32, out=tmp_path / "m.zip", config=S1, bc_expert="sbs", bc_expert_kwargs=[("a", 1)])
    assert not list(tmp_path.iterdir())


def test_dmaps_parameters_pass_as_json_and_unknown_ones_are_refused_before_any_work(tmp_path):
    from baselines.rl.imitation import make_expert

    env = teamgym.make("Foraging-v0")
    expert = make_expert("dmaps", env, params={"min_hold": 0.0, "max_hold": 0.0})
    assert (expert.params.min_hold, expert.params.max_hold) == (0.0, 0.0)
    bad = {"params": {"min_hld": 0}}
    with pytest.raises(TypeError, match=r"unknown dmaps parameter\(s\) \['min_hld'\]"):
        train("Foraging-v0", "maskable_ppo", 32, out=tmp_path / "m.zip", bc_expert="dmaps", bc_expert_kwargs=bad)
    assert not list(tmp_path.iterdir())


def test_pretrain_without_expert_arguments_is_unchanged():
    from stable_baselines3 import PPO

    from baselines.rl.sb3_env import TeamVecEnv

    make = lambda: teamgym.make("BoxPushing-v0", **{**S1, "max_cycles": 20})  # noqa: E731
    venv = TeamVecEnv(make, n_envs=1)
    try:
        model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu")
        record = pretrain(model, make, "sbs", steps=30, epochs=1, seed=0, noise=0.0)
        assert "expert_kwargs" not in record
    finally:
        venv.close()
