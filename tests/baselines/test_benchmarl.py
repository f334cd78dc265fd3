"""BenchMARL (``baselines.rl.benchmarl_task``): MAPPO and IPPO for a few hundred frames on every env id.

Marked ``benchmarl``: run in their own venv by ``bash scripts/run_tests_integrations.sh benchmarl``
(BenchMARL 1.5.2 needs torchrl<0.12); skipped where benchmarl is not installed.
"""

import os

import pytest

if os.environ.get("TEAMGYM_STACK") != "benchmarl":
    pytest.importorskip("benchmarl", reason="needs the benchmarl extra: bash scripts/run_tests_integrations.sh benchmarl")

import torch
from benchmarl.algorithms import IppoConfig, MappoConfig
from benchmarl.experiment import Experiment, ExperimentConfig
from benchmarl.models.mlp import MlpConfig

from baselines.rl.benchmarl_task import ENV_IDS, TeamgymTask
from teamgym.envs.config import ConfigError

pytestmark = pytest.mark.benchmarl
torch.set_num_threads(1)  # tiny networks: more threads only contend on the shared machine

#: Frames per iteration (two iterations each); Rendezvous' macro steps take many control cycles each.
FRAMES = {"RENDEZVOUS": 60}
CYCLES = {"RENDEZVOUS": 120}


def _experiment_config(folder, frames: int) -> ExperimentConfig:
    config = ExperimentConfig.get_from_yaml()
    config.max_n_frames = 2 * frames
    config.on_policy_collected_frames_per_batch = frames
    config.on_policy_n_envs_per_worker = 1
    config.on_policy_n_minibatch_iters = 2
    config.on_policy_minibatch_size = frames // 2
    config.evaluation = False
    config.render = False
    config.loggers = []
    config.create_json = False
    config.checkpoint_interval = 0
    config.checkpoint_at_end = False
    config.save_folder = str(folder)
    return config


def _train(task, algorithm, folder, frames: int) -> None:
    experiment = Experiment(
        task=task,
        algorithm_config=algorithm.get_from_yaml(),
        model_config=MlpConfig.get_from_yaml(),
        critic_model_config=MlpConfig.get_from_yaml(),
        seed=0,
        config=_experiment_config(folder, frames),
    )
    before = [p.detach().clone() for p in experiment.policy.parameters()]
    experiment.run()
    after = list(experiment.policy.parameters())
    assert (experiment.n_iters_performed, experiment.total_frames) == (2, 2 * frames)
    assert all(torch.isfinite(p).all() for p in after)
    assert any(not torch.equal(a, b) for a, b in zip(after, before)), "the policy did not change"


@pytest.mark.parametrize("algorithm", [MappoConfig, IppoConfig], ids=["mappo", "ippo"])
@pytest.mark.parametrize("name", sorted(ENV_IDS))
def test_an_algorithm_trains_on_every_env(name, algorithm, tmp_path):
    task = TeamgymTask[name].get_task({"max_cycles": CYCLES.get(name, 30)})
    _train(task, algorithm, tmp_path, FRAMES.get(name, 100))


def test_mappo_trains_while_a_robot_joins(tmp_path):
    config = {"n_spare_robots": 1, "events": ((20, "add_robot"),), "max_cycles": 30}
    task = TeamgymTask.BOXPUSHING_V0.get_task(config)
    assert task.group_map(task.get_env_fun(1, False, 0, "cpu")()) == {"robot": ["robot_0", "robot_1", "robot_2"]}
    _train(task, MappoConfig, tmp_path, 60)


def test_the_task_follows_the_action_type_and_refuses_a_bad_config():
    assert TeamgymTask.NAVIGATION.get_task().supports_continuous_actions()
    assert TeamgymTask.FORAGING.get_task().supports_discrete_actions()
    exploration = TeamgymTask.EXPLORATION.get_task({"action_type": "operator"})
    assert exploration.supports_discrete_actions() and not exploration.supports_continuous_actions()
    with pytest.raises(ConfigError, match="n_robots"):
        TeamgymTask.NAVIGATION.get_task({"n_robots": -1})
