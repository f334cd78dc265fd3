"""Tianshou (``baselines.rl.tianshou_env``): masked rollouts through Tianshou's PettingZoo path.

Every env id whose action type has masks (Rendezvous-v0 ``next_place``, Exploration-v0
``operator``, Foraging-v0 ``goto_cell``), with ``obs_format="masked"``. Marked ``tianshou``: run in
their own venv by ``bash scripts/run_tests_integrations.sh tianshou``; skipped where tianshou is
not installed.
"""

import os

import pytest

if os.environ.get("TEAMGYM_STACK") != "tianshou":
    pytest.importorskip("tianshou", reason="needs the tianshou extra: bash scripts/run_tests_integrations.sh tianshou")

import numpy as np
from tianshou.algorithm.multiagent.marl import MultiAgentOffPolicyAlgorithm
from tianshou.algorithm.random import MARLRandomDiscreteMaskedOffPolicyAlgorithm
from tianshou.data import Collector
from tianshou.env import DummyVectorEnv

from baselines.rl.tianshou_env import tianshou_env

pytestmark = pytest.mark.tianshou

MASKED = [("Rendezvous-v0", "next_place", 120), ("Exploration-v0", "operator", 40), ("Foraging-v0", "goto_cell", 12)]


def _collector(make, n_envs: int = 2) -> Collector:
    env = make()
    policies = [MARLRandomDiscreteMaskedOffPolicyAlgorithm(env.action_space) for _ in env.agents]
    collector = Collector(MultiAgentOffPolicyAlgorithm(algorithms=policies, env=env), DummyVectorEnv([make] * n_envs))
    collector.reset()
    return collector


@pytest.mark.parametrize(("env_id", "action_type", "cycles"), MASKED, ids=[m[0] for m in MASKED])
def test_masked_random_rollouts_respect_the_masks(env_id, action_type, cycles):
    make = lambda: tianshou_env(env_id, {"action_type": action_type, "max_cycles": cycles})  # noqa: E731
    env = make()
    observation, _ = env.reset(seed=0)
    assert set(observation) == {"agent_id", "obs", "mask"}
    team_env = env.env.unwrapped
    assert observation["mask"] == (team_env.action_mask(observation["agent_id"]) == 1).tolist()
    # teamgym raises on an inadmissible action: a finished collection shows the masks were used.
    stats = _collector(make).collect(n_step=60)
    assert stats.n_collected_steps == 60 and stats.n_collected_episodes >= 1
    assert np.all(stats.lens > 0)


def test_a_robot_that_leaves_does_not_end_the_others_episode():
    config = {"max_cycles": 30, "events": ((5, "remove_robot", "robot_0"),)}
    stats = _collector(lambda: tianshou_env("BoxPushing-v0", config), n_envs=1).collect(n_episode=1)
    assert stats.lens.tolist() == [60]  # 30 joint steps of 2 robots, one AEC turn each


def test_tianshou_needs_fixed_agents():
    with pytest.raises(ValueError, match="fixed_agents=True"):
        tianshou_env("Foraging-v0", {"fixed_agents": False})
