"""The multi-agent training methods of ``baselines.train``: ``--critic``, ``--agent-id``, ``--independent``, ``--net``.

:class:`TeamMethods` holds the four choices, checks them against the algorithm (before any env
is built) and the env (a probe copy), and gives what training needs: the observation features
(:class:`~baselines.rl.agent_features.ObservationFeatures`), the SB3 VecEnv and the policy class
with its ``policy_kwargs``; :meth:`TeamMethods.sidecar` is what the model's sidecar records
(``critic``, ``agent_id``, ``independent`` and ``obs_features``, the part the loader reads).

* ``critic="central"``: :mod:`baselines.rl.central_critic` (the critic also reads the team ``state()``);
* ``agent_id=True``: the robot's index one-hot appended to its observation;
* ``independent=True``: :mod:`baselines.rl.independent` (one policy per robot; implies the one-hot,
  which routes each robot's rows to its own policy; needs a fixed team).
* ``net="cells"``: :mod:`baselines.rl.cell_policy` (the go-to-cell action scored cell by cell over
  the observation's grid layers; a plain parameter-shared policy otherwise, so it can be cloned).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from baselines.rl.agent_features import ObservationFeatures

__all__ = ["CRITICS", "TeamMethods"]

#: ``--critic`` choices: the critic reads the robot's observation (local) or also the team state (central).
CRITICS = ("local", "central")
#: algorithms with a value function that these methods can change (actor-critic policies)
ACTOR_CRITIC = ("ppo", "a2c", "maskable_ppo")


@dataclass(frozen=True)
class TeamMethods:
    """The choices of one run (defaults: today's parameter-shared policy with a local critic)."""

    critic: str = "local"
    agent_id: bool = False
    independent: bool = False
    net: str = "mlp"

    @property
    def features(self) -> ObservationFeatures:
        """The observation parts these methods add (the one-hot also for ``independent``)."""
        return ObservationFeatures(agent_id=self.agent_id or self.independent, team_state=self.critic == "central")

    @property
    def default(self) -> bool:
        """Whether nothing differs from a plain run."""
        return self == TeamMethods()

    def sidecar(self) -> dict[str, Any]:
        """The sidecar fields of a run with these methods."""
        return {
            "critic": self.critic,
            "agent_id": self.agent_id,
            "independent": self.independent,
            "net": self.net,
            "obs_features": self.features.sidecar() if self.features.active else None,
        }

    @classmethod
    def from_sidecar(cls, sidecar: Mapping[str, Any] | None) -> TeamMethods:
        """The methods a sidecar records (a sidecar without them: a plain run)."""
        sidecar = sidecar or {}
        return cls(
            str(sidecar.get("critic") or "local"),
            bool(sidecar.get("agent_id")),
            bool(sidecar.get("independent")),
            str(sidecar.get("net") or "mlp"),
        )

    def check(self, algo: str, bc: bool = False, workers: int = 1) -> None:
        """``ValueError`` of one line for a choice the algorithm or the other settings cannot take (before any env)."""
        if self.critic not in CRITICS:
            raise ValueError(f"critic must be one of {', '.join(CRITICS)}, got {self.critic!r}")
        if self.critic == "central" and algo not in ACTOR_CRITIC:
            raise ValueError(
                f"--critic central needs an algorithm with a value function (ppo, a2c, maskable_ppo); {algo} has none"
            )
        if self.independent and algo not in ACTOR_CRITIC:
            raise ValueError(f"--independent needs an actor-critic algorithm (ppo, a2c, maskable_ppo), not {algo}")
        self._check_net(algo)
        if replace(self, net="mlp").default:
            return
        if algo not in ACTOR_CRITIC:  # e.g. recurrent_ppo: its LSTM policy takes no widened inputs yet
            raise ValueError(
                f"--critic central, --agent-id and --independent need ppo, a2c or maskable_ppo; {algo} does not take them yet"
            )
        if bc:
            raise ValueError(
                "behaviour cloning (--bc-expert, or a preset's bc) fits a plain policy; it cannot be combined with "
                "--critic central, --agent-id or --independent"
            )
        if workers > 1:
            raise ValueError(
                "--workers > 1 steps plain copies; it cannot be combined with --critic central, --agent-id or --independent"
            )

    def _check_net(self, algo: str) -> None:
        from baselines.rl.cell_policy import NETS

        if self.net not in NETS:
            raise ValueError(f"net must be one of {', '.join(NETS)}, got {self.net!r}")
        if self.net == "mlp":
            return
        if algo not in ACTOR_CRITIC:
            raise ValueError(f"--net cells needs ppo, a2c or maskable_ppo (a Discrete cell action), not {algo}")
        if self.critic == "central" or self.independent:
            raise ValueError("--net cells cannot be combined with --critic central or --independent yet")

    def check_env(self, env: Any) -> None:
        """``ValueError`` of one line if the env (a probe copy, reset here) cannot take these methods."""
        if self.features.active:
            self.features.dims(env)  # flat Box observations
        if self.net == "cells":
            from baselines.rl.cell_policy import grid_layout

            grid_layout(env)  # a Discrete cell action and grid layers in a flat observation
        if self.independent:
            observations, _ = env.reset(seed=0)
            missing = [a for a in env.possible_agents if a not in observations]
            if missing:
                raise ValueError(
                    f"--independent needs a fixed team (every possible agent in the episode from the start); "
                    f"{', '.join(missing)} start outside it (spare robots, e.g. n_spare_robots > 0)"
                )

    def make_venv(self, env_fn: Callable[[], Any], n_envs: int) -> Any:
        """The training VecEnv: a :class:`TeamVecEnv`, widened by :class:`FeatureTeamVecEnv` when features are on."""
        from baselines.rl.sb3_env import TeamVecEnv

        if not self.features.active:
            return TeamVecEnv(env_fn, n_envs=n_envs)
        from baselines.rl.agent_features import FeatureTeamVecEnv

        return FeatureTeamVecEnv(env_fn, n_envs=n_envs, features=self.features)

    def policy(self, algo: str, env: Any) -> tuple[Any, dict[str, Any]]:
        """SB3's ``policy`` argument (the algorithm's own alias, or a class) and the ``policy_kwargs`` these methods add."""
        features = self.features
        actor_dim = features.actor_dim(env) if self.critic == "central" else None
        if self.independent:
            from baselines.rl.independent import independent_policy_class

            own, _, _ = features.dims(env)
            return independent_policy_class(algo), {"n_agents": len(env.possible_agents), "id_start": own, "actor_dim": actor_dim}
        if actor_dim is not None:
            from baselines.rl.central_critic import central_policy_class

            return central_policy_class(algo), {"actor_dim": actor_dim}
        if self.net == "cells":
            from baselines.rl.cell_policy import cell_policy_class, grid_layout

            return cell_policy_class(algo), {"layout": grid_layout(env)}
        from baselines.rl.sb3_policy import policy_name

        return policy_name(algo), {}
