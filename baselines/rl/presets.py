"""RL presets: per env, the config, algorithm, hyper-parameters and budget with which
``python -m baselines.train --preset NAME`` trains a useful agent on a 2-core machine.

A preset is a JSON file in ``baselines/rl/presets/`` (data, not code, so a sweep can write
new ones): ``env``, ``algo``, ``config`` (env config keys: they change the encoding of
actions and observations and the reward weights, and may choose the setting trained in --
BoxPushing's ``situation``, Foraging's ``n_robots`` -- never how success is judged),
``n_envs``, ``timesteps``, ``hyperparameters`` (SB3 keyword arguments, including
``policy_kwargs``), ``bc`` (optional behaviour cloning: ``expert``, ``steps``,
``epochs``, optional ``noise`` of the executed expert actions, ``batch_size`` of the
fit and ``expert_kwargs`` (the expert's constructor arguments, e.g. ``{"look_cycles": 0}``
for ``sbs``, ``{"params": {"min_hold": 0.0}}`` for ``dmaps``), and optional DAgger rounds
``dagger_rounds``, ``dagger_steps``, ``dagger_epochs``), ``eval`` (optional held-out evaluation while training: ``every``,
``episodes``, ``seed``), ``init`` (optional: a saved model or shipped agent whose policy
weights the new run starts from, as ``--init``), ``critic`` (optional: ``local`` or ``central``,
as ``--critic``), ``agent_id`` (optional: ``true`` as ``--agent-id``), ``net`` (optional: ``mlp`` or ``cells``,
as ``--net``), ``message_actions``
(optional: how a motion ⊕ message action is flattened, ``levels``, ``tokens``, ``vocab``, as
``--message-levels/--message-tokens/--message-vocab``), ``changes`` (each config key and hyper-parameter the preset sets, with
why) and ``measured`` (what the preset reached, with the command). docs/training.md lists them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["PRESET_DIR", "Preset", "load_preset", "presets"]

PRESET_DIR = Path(__file__).with_name("presets")
_KEYS = {
    "env",
    "algo",
    "config",
    "n_envs",
    "timesteps",
    "hyperparameters",
    "bc",
    "eval",
    "changes",
    "measured",
    "description",
    "init",
    "critic",
    "agent_id",
    "net",
    "message_actions",
}


@dataclass(frozen=True)
class Preset:
    """One training recipe (see the module docstring)."""

    name: str
    env: str
    algo: str
    config: dict[str, Any] = field(default_factory=dict)
    n_envs: int = 4
    timesteps: int = 100_000
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    bc: dict[str, Any] | None = None
    eval: dict[str, Any] | None = None
    changes: dict[str, str] = field(default_factory=dict)
    measured: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    init: str | None = None
    critic: str | None = None
    agent_id: bool | None = None
    net: str | None = None
    message_actions: dict[str, int] | None = None


def presets() -> list[str]:
    """Names of the shipped presets."""
    return sorted(path.stem for path in PRESET_DIR.glob("*.json"))


def load_preset(name: str) -> Preset:
    """The preset ``name``; ``KeyError`` naming the known ones if there is none."""
    path = PRESET_DIR / f"{name}.json"
    if not path.is_file():
        raise KeyError(f"unknown preset {name!r}; available: {', '.join(presets()) or 'none'}")
    data = json.loads(path.read_text())
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        raise ValueError(f"preset {name!r} has unknown key(s) {unknown}; valid keys are {sorted(_KEYS)}")
    missing = [key for key in ("env", "algo") if key not in data]
    if missing:
        raise ValueError(f"preset {name!r} lacks {missing}")
    message = data.get("message_actions")
    if message is not None and (not isinstance(message, dict) or set(message) - {"levels", "tokens", "vocab"}):
        raise ValueError(f"preset {name!r}: message_actions must be an object of levels, tokens, vocab; got {message!r}")
    return Preset(name=name, **data)
