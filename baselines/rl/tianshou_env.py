"""teamgym envs through Tianshou's PettingZoo path (``tianshou.env.PettingZooEnv``); needs the ``tianshou`` extra.

Tianshou wraps an AEC env (teamgym's ``make_aec``: PettingZoo's ``parallel_to_aec``) and reads
masks from ``{"observation", "action_mask"}`` observations, so the env is made with
``obs_format="masked"`` (discrete action types) unless ``config`` says otherwise, and with
``fixed_agents=True``: Tianshou ends the episode as soon as the agent whose turn it is reports
done, so without a fixed agent list the first robot to finish (removed, arrived) would end every
robot's episode (docs/scale_out.md).
"""

from __future__ import annotations

from typing import Any


def tianshou_env(env_id: str, config: dict[str, Any] | None = None) -> Any:
    """``env_id`` (``config`` overrides; default ``obs_format="masked"``, ``fixed_agents=True``) as a Tianshou env."""
    config = {"obs_format": "masked", **(config or {})}
    if config.get("fixed_agents", True) is not True:
        raise ValueError(f"tianshou_env: fixed_agents={config['fixed_agents']!r}; Tianshou needs fixed_agents=True")
    config["fixed_agents"] = True
    from tianshou.env import PettingZooEnv

    import teamgym

    return PettingZooEnv(teamgym.make_aec(env_id, **config))
