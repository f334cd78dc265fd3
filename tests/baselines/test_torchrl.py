"""TorchRL (``baselines.rl.torchrl_env``): specs and collector rollouts on every env id, robots joining.

Marked ``torchrl``: run in their own venv by ``bash scripts/run_tests_integrations.sh torchrl``
(which sets ``TEAMGYM_STACK=torchrl``, so a broken install fails instead of skipping); skipped
where torchrl is not installed.
"""

import os

import pytest

if os.environ.get("TEAMGYM_STACK") != "torchrl":
    pytest.importorskip("torchrl", reason="needs the torchrl extra: bash scripts/run_tests_integrations.sh torchrl")

import torch
from torchrl.collectors import Collector
from torchrl.envs.utils import check_env_specs

import teamgym
from baselines.rl.torchrl_env import torchrl_env

pytestmark = pytest.mark.torchrl
torch.set_num_threads(1)  # tiny networks: more threads only contend on the shared machine

#: Episode lengths that give a few episodes in a short rollout (Rendezvous' macro steps take many cycles).
CYCLES = {"Rendezvous-v0": 120}


@pytest.mark.parametrize("env_id", teamgym.envs())
def test_specs_hold_and_a_collector_rolls_out(env_id):
    env = torchrl_env(env_id, {"max_cycles": CYCLES.get(env_id, 15)}, seed=0)
    n_robots = len(teamgym.make(env_id).possible_agents)
    assert env.group_map == {"robot": [f"robot_{i}" for i in range(n_robots)]}
    check_env_specs(env, seed=0)
    # env.rand_action samples from the action spec, whose mask the wrapper updates every step: an
    # inadmissible action would make teamgym raise, so a finished rollout shows the masks arrive.
    collector = Collector(env, policy=env.rand_action, frames_per_batch=20, total_frames=40)
    batches = list(collector)
    collector.shutdown()
    assert [b.batch_size for b in batches] == [torch.Size([20])] * 2
    done = torch.cat([b["next", "done"] for b in batches])
    assert done.any(), "the rollout should pass an episode end and reset"
    observation = torch.cat([b["robot", "observation"] for b in batches])
    assert observation.shape[1:] == (n_robots, env.observation_spec["robot", "observation"].shape[-1])
    assert (observation[..., -1] == 1).all()  # present: no robot of these configs leaves early
    if "action_mask" in env.observation_spec["robot"]:
        mask = torch.cat([b["robot", "action_mask"] for b in batches])
        action = torch.cat([b["robot", "action"] for b in batches])
        assert mask.gather(-1, action.unsqueeze(-1)).all()


def test_a_robot_that_joins_and_one_that_leaves_keep_their_slots():
    config = {
        "n_spare_robots": 1,
        "events": ((5, "remove_robot", "robot_0"), (20, "add_robot")),
        "max_cycles": 30,
    }
    env = torchrl_env("BoxPushing-v0", config, seed=0)
    check_env_specs(env, seed=0)
    collector = Collector(env, policy=env.rand_action, frames_per_batch=30, total_frames=30)
    (batch,) = list(collector)
    collector.shutdown()
    present = batch["robot", "observation"][..., -1]  # (frames, robots)
    steps = torch.arange(30)
    assert torch.equal(present[:, 0], (steps <= 5).float())  # removed at cycle 5; its last step is step 5
    assert torch.equal(present[:, 1], torch.ones(30))
    assert torch.equal(present[:, 2], (steps >= 20).float())  # joins at the end of step 20
    reward = batch["next", "robot", "reward"].squeeze(-1)
    assert (reward[5:, 0] == 0).all() and (reward[:20, 2] == 0).all()
    assert batch["next", "done"][-1].all() and not batch["next", "done"][:-1].any()


def test_torchrl_needs_fixed_agents_and_flat_observations_with_masks():
    with pytest.raises(ValueError, match="fixed_agents=True"):
        torchrl_env("Navigation-v0", {"fixed_agents": False})
    with pytest.raises(ValueError, match="use 'flat'"):
        torchrl_env("Rendezvous-v0", {"obs_format": "masked"})
    assert "observation" in torchrl_env("Navigation-v0", {"obs_format": "dict"}).observation_spec["robot"]
