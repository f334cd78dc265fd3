"""teamgym as a BenchMARL task family; needs the ``benchmarl`` extra (docs/scale_out.md).

``TeamgymTask`` enumerates the env ids; ``TeamgymTask.NAVIGATION.get_task({"max_cycles": 50})``
gives a :class:`TeamgymClass` whose config holds teamgym config overrides (``env_id`` is
implied by the member; ``fixed_agents`` is always True). The envs are TorchRL
``PettingZooWrapper``s from :func:`baselines.rl.torchrl_env.torchrl_env`, with the env's
global ``state()`` for centralised critics (MAPPO). All robots form one group, ``"robot"``,
so ``share_policy_params=True`` gives one shared policy. Whether the task takes continuous or
discrete actions follows the configured ``action_type`` (``Box`` or ``Discrete`` space);
discrete masks reach the algorithms as ``("robot", "action_mask")``.

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig
    from baselines.rl.benchmarl_task import TeamgymTask

    task = TeamgymTask.NAVIGATION.get_task({"max_cycles": 100})
    Experiment(task, MappoConfig.get_from_yaml(), MlpConfig.get_from_yaml(), ExperimentConfig.get_from_yaml(), seed=0).run()
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from benchmarl.environments.common import Task, TaskClass
from gymnasium import spaces
from torchrl.data import Composite
from torchrl.envs import EnvBase

import teamgym
from baselines.rl.torchrl_env import torchrl_env

#: BenchMARL task name -> teamgym env id.
ENV_IDS: dict[str, str] = {
    "NAVIGATION": "Navigation-v0",
    "EXPLORATION": "Exploration-v0",
    "RENDEZVOUS": "Rendezvous-v0",
    "FORAGING": "Foraging-v0",
    "BOXPUSHING_V0": "BoxPushing-v0",
    "BOXPUSHING_V1": "BoxPushing-v1",
}


class TeamgymClass(TaskClass):
    """One teamgym env id with config overrides (``self.config``) as a BenchMARL task."""

    def __init__(self, name: str, config: dict[str, Any] | None) -> None:
        if name not in ENV_IDS:
            raise KeyError(f"unknown teamgym task {name!r}; tasks are {sorted(ENV_IDS)}")
        super().__init__(name, dict(config or {}))
        probe = teamgym.make(self.env_id, **{**self.config, "fixed_agents": True})  # a bad config fails here, once
        self._action_space = probe.action_space(probe.possible_agents[0])
        self._max_steps = int(probe.config.cycle_limit)
        probe.close()

    @property
    def env_id(self) -> str:
        return ENV_IDS[self.name]

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed: int | None, device: Any) -> Callable[[], EnvBase]:
        env_id, config = self.env_id, dict(self.config)
        return lambda: torchrl_env(env_id, config, seed=seed, return_state=True, device=device)

    def supports_continuous_actions(self) -> bool:
        return isinstance(self._action_space, spaces.Box)

    def supports_discrete_actions(self) -> bool:
        return isinstance(self._action_space, spaces.Discrete)

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        return self._max_steps

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return env.group_map

    def _group_keys(self, env: EnvBase, keep: str) -> Composite | None:
        """The observation spec with only the ``keep`` entry of each group (None if no group has one)."""
        spec = env.observation_spec.clone()
        for group in self.group_map(env):
            group_spec = spec[group]
            for key in list(group_spec.keys()):
                if key != keep:
                    del group_spec[key]
            if group_spec.is_empty():
                del spec[group]
        if "state" in spec:
            del spec["state"]
        return None if spec.is_empty() else spec

    def observation_spec(self, env: EnvBase) -> Composite:
        return self._group_keys(env, "observation")

    def info_spec(self, env: EnvBase) -> Composite | None:
        return self._group_keys(env, "info")

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return self._group_keys(env, "action_mask")

    def state_spec(self, env: EnvBase) -> Composite | None:
        if "state" in env.observation_spec:
            return Composite({"state": env.observation_spec["state"].clone()})
        return None

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec

    @staticmethod
    def env_name() -> str:
        return "teamgym"


class TeamgymTask(Task):
    """The teamgym env ids as BenchMARL tasks (``TeamgymTask.FORAGING.get_task(config)``)."""

    NAVIGATION = None
    EXPLORATION = None
    RENDEZVOUS = None
    FORAGING = None
    BOXPUSHING_V0 = None
    BOXPUSHING_V1 = None

    @staticmethod
    def associated_class() -> type[TaskClass]:
        return TeamgymClass

    def get_task(self, config: dict[str, Any] | None = None) -> TaskClass:
        """The task with ``config`` (teamgym overrides; default: the env's defaults, no YAML file needed)."""
        return TeamgymClass(self.name, config or {})
