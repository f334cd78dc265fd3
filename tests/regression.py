"""Regression fingerprints of every env and action type (the core refactor's safety net).

For each registered env and each ``action_type`` it offers, seeds 0–9 run up to
``STEPS`` steps with actions drawn from a generator seeded by the episode seed (admissible
ones where the env masks actions). The fingerprint is a SHA-256 over the flat observations,
rewards, terminations, truncations and the numeric ``infos`` values present when the
fixture was recorded (string-valued infos were later replaced by indices, so they are left
out; keys added later are ignored).

``python -m tests.regression record`` adds the cases missing from ``tests/data/regression_hashes.json``
(a new env or action type; recorded hashes are never rewritten); the test
``tests/test_regression.py`` recomputes every fingerprint with ``obs_format="flat"``.
"""

from __future__ import annotations

import hashlib
import json
import sys
import typing
from pathlib import Path

import numpy as np

import teamgym

STEPS = 300
SEEDS = range(10)
FIXTURE = Path(__file__).parent / "data" / "regression_hashes.json"


def cases() -> list[tuple[str, str]]:
    """(env id, action type) for every registered env and every action type it offers."""
    out = []
    for env_id in teamgym.envs():
        hint = typing.get_type_hints(teamgym.env_class(env_id).config_class).get("action_type")
        kinds = typing.get_args(hint) if hint is not None else ()
        out.extend((env_id, kind) for kind in kinds)
    return out


def _sample(env, agent: str, infos: dict, rng: np.random.Generator):
    space = env.action_space(agent)
    mask = infos.get(agent, {}).get("action_mask")
    if mask is not None:
        return int(rng.choice(np.flatnonzero(mask)))
    if hasattr(space, "n"):
        return int(rng.integers(space.start, space.start + space.n))
    return rng.uniform(space.low, space.high).astype(space.dtype)


def _numeric_items(info: dict, keys: list[str] | None) -> list:
    items = []
    for key in sorted(info):
        value = info[key]
        if isinstance(value, str) or (keys is not None and key not in keys):
            continue
        items.append((key, np.asarray(value).tolist()))
    return items


def fingerprint(env_id: str, action_type: str, seed: int, info_keys: list[str] | None = None, **extra) -> tuple[str, list[str]]:
    """SHA-256 of one seeded random rollout and the info keys it hashed."""
    env = teamgym.make(env_id, action_type=action_type, **extra)
    digest = hashlib.sha256()
    rng = np.random.default_rng(seed)
    observations, infos = env.reset(seed=seed)
    seen: set[str] = set()

    def feed(obs, infos, *more):
        for agent in sorted(obs):
            digest.update(agent.encode())
            digest.update(np.asarray(obs[agent], dtype=np.float32).tobytes())
        for table in more:
            digest.update(repr(sorted(table.items())).encode())
        for agent in sorted(infos):
            items = _numeric_items(infos[agent], info_keys)
            seen.update(k for k, _ in items)
            digest.update(repr(items).encode())

    feed(observations, infos)
    for _ in range(STEPS):
        if not env.agents:
            break
        actions = {a: _sample(env, a, infos, rng) for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        feed(observations, infos, rewards, terminations, truncations)
    return digest.hexdigest(), sorted(seen)


def record(existing: dict | None = None) -> dict:
    """Fingerprints of the cases missing from ``existing`` (recorded ones are never overwritten)."""
    data: dict = existing or {"steps": STEPS, "seeds": list(SEEDS), "cases": {}}
    for env_id, kind in cases():
        if f"{env_id}/{kind}" in data["cases"]:
            continue
        hashes, keys = [], set()
        for seed in SEEDS:
            h, k = fingerprint(env_id, kind, seed)
            hashes.append(h)
            keys.update(k)
            print(env_id, kind, seed, h[:12], flush=True)
        data["cases"][f"{env_id}/{kind}"] = {"hashes": hashes, "info_keys": sorted(keys)}
    return data


if __name__ == "__main__":
    if sys.argv[1:] != ["record"]:
        sys.exit("usage: python -m tests.regression record")
    FIXTURE.parent.mkdir(parents=True, exist_ok=True)
    existing = json.loads(FIXTURE.read_text()) if FIXTURE.exists() else None
    FIXTURE.write_text(json.dumps(record(existing), indent=1) + "\n")
