"""teamgym envs as TorchRL envs (``torchrl.envs.PettingZooWrapper``); needs the ``torchrl`` extra (docs/scale_out.md).

TorchRL's wrapper sends an action for every agent of a group at every step and builds its
specs from the agents present at reset, so the env is made with ``fixed_agents=True``
(:mod:`teamgym.envs.fixed_agents`): robots that finished, or spares not yet added, stay in
the group with the observation field ``present`` = 0 and their actions are ignored. All the
robots of an env form one group, ``"robot"``. Discrete masks (Rendezvous-v0 ``next_place``,
Exploration-v0 ``operator``, Foraging-v0 ``goto_cell``) arrive through ``infos[agent]["action_mask"]``
and become ``("robot", "action_mask")``, which TorchRL's random actions and masked
distributions respect; such envs need ``obs_format="flat"`` (PettingZooWrapper fails on a mask
in both the observation and the infos).
"""

from __future__ import annotations

from typing import Any

#: Settings of ``PettingZooWrapper`` that teamgym needs: every agent is in every step
#: (``fixed_agents=True``), so no per-agent ``mask``; the episode ends when every robot is done.
WRAPPER_SETTINGS: dict[str, Any] = {"use_mask": False, "done_on_any": False}


def torchrl_env(
    env_id: str,
    config: dict[str, Any] | None = None,
    *,
    seed: int | None = None,
    categorical_actions: bool = True,
    return_state: bool = False,
    device: Any = "cpu",
) -> Any:
    """``env_id`` with ``config`` overrides (``fixed_agents`` is set to True) as a TorchRL ``PettingZooWrapper``.

    ``return_state`` adds the env's global ``state()`` (a centralised critic's input) to the tensordict.
    """
    config = dict(config or {})
    if config.get("fixed_agents", True) is not True:
        raise ValueError(f"torchrl_env: fixed_agents={config['fixed_agents']!r}; TorchRL needs fixed_agents=True")
    config["fixed_agents"] = True
    from torchrl.envs import PettingZooWrapper

    import teamgym

    env = teamgym.make(env_id, **config)
    if "action_mask" in env.info_schema() and env.config.obs_format != "flat":
        raise ValueError(
            f"torchrl_env: obs_format={env.config.obs_format!r} with a masked action type; use 'flat' (PettingZooWrapper "
            "fails when the mask is in both the observation and the infos; the infos carry it to TorchRL)"
        )
    return PettingZooWrapper(
        env,
        categorical_actions=categorical_actions,
        return_state=return_state,
        seed=seed,
        device=device,
        **WRAPPER_SETTINGS,
    )
