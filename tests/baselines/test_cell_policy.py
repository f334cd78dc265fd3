"""``baselines.train --net cells``: the per-cell actor of go-to-cell actions (:mod:`baselines.rl.cell_policy`).

Its layout read from the env, the cell order of its logits (the env's ``gy * nx + gx``), the
egocentric channels, behaviour cloning into it, and train → save → ``evaluate --policy sb3:``
giving training's own evaluation figures; bad combinations are one-line errors.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import torch as th  # noqa: E402
from sb3_contrib import MaskablePPO  # noqa: E402

import teamgym  # noqa: E402
from baselines.rl.cell_policy import CellExtractor, MaskableCellPolicy, grid_layout  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy  # noqa: E402
from baselines.rl.team_methods import TeamMethods  # noqa: E402
from baselines.train import main as train_main  # noqa: E402
from tests.train_support import evaluate_matches_training  # noqa: E402

GRID = {"observe_world_model": True, "observe_novelty": True}
SMALL = ["--set", "observe_world_model=True", "--set", "observe_novelty=True", "--set", "time_limit=3", "--set", "consume_time=1"]
PPO_ARGS = ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=2", "--verbose", "0", "--n-envs", "1"]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def test_the_layout_names_the_grid_fields_and_the_pose():
    env = teamgym.make("Foraging-v0", **GRID)
    layout = grid_layout(env)
    slices = env.unwrapped.layout.slices
    assert layout["grid_shape"] == [12, 15]
    assert layout["grids"] == [[slices["world_model"].start, 2], [slices["novelty"].start, 1]]
    assert layout["pose"] == slices["pose_estimate"].start and layout["cell_size"] == pytest.approx(0.2)
    novelty_only = teamgym.make("Foraging-v0", observe_novelty=True)
    assert grid_layout(novelty_only)["grids"] == [[novelty_only.unwrapped.layout.slices["novelty"].start, 1]]


@pytest.mark.parametrize(
    "config,needle",
    [({}, "grid layers"), ({**GRID, "action_type": "velocity"}, "Discrete"), ({**GRID, "obs_format": "dict"}, "flat")],
    ids=["no-grid", "velocity", "dict"],
)
def test_envs_without_a_cell_action_over_grid_layers_are_refused(config, needle):
    with pytest.raises(ValueError, match=needle):
        grid_layout(teamgym.make("Foraging-v0", **config))


def _novelty_only_extractor(layout, width):
    """An extractor whose score is relu(novelty) at each cell (every other weight zero)."""
    net = CellExtractor(width, layout, channels=4)
    with th.no_grad():
        for parameter in net.parameters():
            parameter.zero_()
        novelty_channel = 2  # the grid channels: world model targets, robots, then novelty
        net.cells_in.weight[0, novelty_channel, 0, 0] = 1.0
        net.per_cell.weight[0, 0, 0, 0] = 1.0
        net.score.weight[0, 0, 0, 0] = 1.0
    return net


def test_logits_are_in_the_envs_cell_order():
    env = teamgym.make("Foraging-v0", **GRID)
    layout, fields = grid_layout(env), env.unwrapped.layout
    net = _novelty_only_extractor(layout, fields.size)
    rng = np.random.default_rng(0)
    obs = np.zeros((5, fields.size), dtype=np.float32)
    novelty = rng.random((5, 12, 15)).astype(np.float32)
    obs[:, fields.slices["novelty"]] = novelty.reshape(5, -1)
    logits = net.forward_actor(th.as_tensor(obs)).detach().numpy()
    np.testing.assert_allclose(logits, novelty.reshape(5, -1), rtol=1e-6)
    best = logits.argmax(axis=1)
    grid = env.unwrapped.grid
    for row, index in enumerate(best):
        gx, gy = grid.cell_at(int(index))
        assert novelty[row, gy, gx] == novelty[row].max()


def test_egocentric_channels_follow_the_pose():
    env = teamgym.make("Foraging-v0", **GRID)
    layout, fields = grid_layout(env), env.unwrapped.layout
    net = CellExtractor(fields.size, layout, channels=4)
    obs = np.zeros((1, fields.size), dtype=np.float32)
    obs[0, fields.slices["pose_estimate"]] = [1.1, 0.7, np.pi / 2]  # the centre of cell (5, 3), facing +y
    ego = net._ego(th.as_tensor(obs))[0].numpy()  # (5, ny, nx): dx, dy, distance, cos, sin of the bearing
    assert ego[2, 3, 5] == pytest.approx(0.0, abs=1e-6)
    assert ego[2].min() == pytest.approx(0.0, abs=1e-6)
    ahead = ego[:, 6, 5]  # three cells along +y: straight ahead
    assert ahead[3] == pytest.approx(1.0, abs=1e-6) and ahead[4] == pytest.approx(0.0, abs=1e-6)
    left = ego[:, 3, 2]  # three cells along -x: on the robot's left when it faces +y
    assert left[4] == pytest.approx(1.0, abs=1e-6)


def test_the_policy_masks_cells_and_reloads(tmp_path):
    def make():
        return teamgym.make("Foraging-v0", **GRID)

    venv = TeamVecEnv(make, n_envs=1)
    methods = TeamMethods(net="cells")
    policy, kwargs = methods.policy("maskable_ppo", make())
    assert policy is MaskableCellPolicy
    model = MaskablePPO(policy, venv, n_steps=16, batch_size=16, policy_kwargs=kwargs, seed=0, device="cpu")
    assert isinstance(model.policy.action_net, th.nn.Identity)
    obs = venv.reset()
    masks = np.ones((venv.num_envs, 180), dtype=bool)
    masks[:, 100:] = False
    actions, _ = model.predict(obs, action_masks=masks, deterministic=False)
    assert (actions < 100).all()
    model.save(tmp_path / "m.zip")
    loaded = MaskablePPO.load(tmp_path / "m.zip", device="cpu")
    assert type(loaded.policy) is MaskableCellPolicy and loaded.policy.layout == kwargs["layout"]
    a, _ = model.predict(obs, action_masks=masks, deterministic=True)
    b, _ = loaded.predict(obs, action_masks=masks, deterministic=True)
    np.testing.assert_array_equal(a, b)
    venv.close()


@pytest.mark.parametrize("methods", [[], ["--agent-id"]], ids=["plain", "agent-id"])
def test_train_save_and_evaluate_give_the_same_figures(methods, tmp_path):
    out = tmp_path / "m.zip"
    args = ["--env", "Foraging-v0", "--algo", "maskable_ppo", "--net", "cells", "--timesteps", "64", *SMALL, *PPO_ARGS]
    evaluation = ["--eval-every", "64", "--eval-episodes", "2", "--eval-seed", "500"]
    assert train_main([*args, *methods, *evaluation, "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["net"] == "cells" and TeamMethods.from_sidecar(sidecar).net == "cells"
    assert sidecar["agent_id"] is bool(methods)
    env = teamgym.make("Foraging-v0", **GRID, time_limit=3.0, consume_time=1.0)
    policy = SB3Policy.load(out, env)
    assert type(policy.model.policy) is MaskableCellPolicy
    assert policy.model.observation_space.shape == (env.unwrapped.layout.size + 2 * bool(methods),)
    evaluate_matches_training(out, 2, 500, tmp_path / "eval")


def test_behaviour_cloning_fits_the_cell_policy(tmp_path):
    out = tmp_path / "m.zip"
    args = ["--env", "Foraging-v0", "--algo", "maskable_ppo", "--net", "cells", "--timesteps", "32", *SMALL, *PPO_ARGS]
    clone = ["--bc-expert", "dmaps", "--bc-steps", "120", "--bc-epochs", "2", "--bc-noise", "0"]
    assert train_main([*args, *clone, "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["net"] == "cells" and sidecar["bc"]["expert"] == "dmaps"
    assert type(MaskablePPO.load(out, device="cpu").policy) is MaskableCellPolicy


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--algo", "maskable_ppo", "--net", "cells"], "grid layers"),
        (["--algo", "ppo", "--net", "cells", *SMALL, "--set", "action_type=velocity"], "Discrete"),
        (["--algo", "dqn", "--net", "cells", *SMALL], "needs ppo, a2c or maskable_ppo"),
        (["--algo", "maskable_ppo", "--net", "cells", "--critic", "central", *SMALL], "cannot be combined"),
        (["--algo", "maskable_ppo", "--net", "cnn", *SMALL], "invalid choice"),
    ],
    ids=["no-grid", "velocity", "dqn", "central", "typo"],
)
def test_bad_combinations_are_one_line_errors_before_any_work(args, needle, tmp_path, capsys):
    out = tmp_path / "m.zip"
    assert train_main(["--env", "Foraging-v0", "--timesteps", "32", "--verbose", "0", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1 and needle in err, err
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_resume_keeps_the_net(tmp_path, capsys):
    out = tmp_path / "m.zip"
    args = ["--env", "Foraging-v0", "--algo", "maskable_ppo", "--net", "cells", "--timesteps", "32", *SMALL, *PPO_ARGS]
    assert train_main([*args, "--out", str(out)]) == 0
    assert train_main(["--resume", str(out), "--timesteps", "32", "--net", "mlp", "--verbose", "0"]) == 2
    assert "net='cells'" in capsys.readouterr().err
    assert train_main(["--resume", str(out), "--timesteps", "32", "--verbose", "0"]) == 0
    assert type(MaskablePPO.load(out, device="cpu").policy) is MaskableCellPolicy
