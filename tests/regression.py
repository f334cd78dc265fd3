"""Regression fingerprints of every env and action type (the core refactor's safety net).

For each registered env and each ``action_type`` it offers, seeds 0–9 run up to
``STEPS`` steps with actions drawn from a generator seeded by the episode seed (admissible
ones where the env masks actions). The fingerprint is a SHA-256 over the flat observations,
rewards, terminations, truncations and the numeric ``infos`` values present when the
fixture was recorded (string-valued infos were later replaced by indices, so they are left
out; keys added later are ignored, and so are metrics at their "not known yet" sentinel of
``env.info_schema()``, which were absent keys when the fixture was recorded).

``python -m tests.regression record`` adds the cases missing from ``tests/data/regression_hashes.json``
(a new env or action type; recorded hashes are never rewritten); the test
``tests/envs/test_regression.py`` recomputes every fingerprint with ``obs_format="flat"``.

Observation hashes (issue 15, a second fixture recorded before the speed work): for every
registered env, every ``action_type`` and both ``obs_format`` values, the learned message
(``comm_dim``), the env's own observation options (``OBS_OPTIONS``) and the Navigation
settings of the ``nash`` experiments (``NAV_SCENES``), seeds ``OBS_SEEDS`` run up to
``OBS_STEPS`` steps with actions from a seeded ``numpy`` generator (admissible ones where
masked). :func:`obs_hash` hashes the raw bytes of every observation field and of the rewards,
terminations, truncations and every numeric info (as float64), so nothing depends on ``repr``
or on ``space.sample``. ``python -m tests.regression obs-hashes --write`` rewrites
``tests/data/obs_hashes.json`` from the current code (only do that on purpose: the fixture
is the reference the optimisations are checked against); without ``--write`` it lists the
cases that differ. ``tests/envs/test_obs_hashes.py`` recomputes every hash and never writes.

Both fixtures hold for numpy's AVX2 kernels: on a CPU with AVX-512 the tests turn those
kernels off (``tests/conftest.py``), and so does this module when run as a script (it
imports the conftest first, before numpy loads).
"""

from __future__ import annotations

import tests.conftest  # noqa: F401  (first: numpy without its AVX-512 kernels, as in the tests)

# isort: split

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


def _numeric_items(info: dict, keys: list[str] | None, schema: dict | None = None) -> list:
    """The numeric infos hashed: every key (of ``keys``) but metrics still at their "not known yet" sentinel.

    Those sentinels (``env.info_schema()``: a time to goal of -1 before arrival) were absent keys
    when the fixture was recorded; leaving them out hashes what the env knows, as then.
    """
    items = []
    for key in sorted(info):
        value = info[key]
        if isinstance(value, str) or (keys is not None and key not in keys):
            continue
        spec = (schema or {}).get(key)
        if spec is not None and spec.kind == "metric" and spec.sentinel and np.shape(value) == () and value == spec.missing:
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
            items = _numeric_items(infos[agent], info_keys, env.info_schema())
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


OBS_STEPS = 200
OBS_SEEDS = (0, 1)
OBS_FIXTURE = Path(__file__).parent / "data" / "obs_hashes.json"
#: Config options of a task that change what its robots observe (besides ``obs_format``, ``comm_dim``).
OBS_OPTIONS: dict[str, tuple[dict, ...]] = {
    "Foraging-v0": ({"observe_world_model": True},),
    "Rendezvous-v0": ({"protocol_messages": True},),
}
#: Navigation settings of the ``nash`` baseline's experiments and benchmark (``heading`` actions).
NAV_SCENES: tuple[dict, ...] = (
    {"n_robots": 5, "dt": 0.2},
    {"n_robots": 5, "dt": 0.2, "speed_rule": "any"},
    {"n_robots": 5, "dt": 0.2, "walls": False, "obstacle_motion": "straight", "robot_radius": 0.05},
    {"n_robots": 3, "actuation_delay": 0.1, "layout": "circle"},
)


def _label(config: dict) -> str:
    return ",".join(f"{key}={value}" for key, value in config.items())


def obs_cases() -> dict[str, tuple[str, dict]]:
    """Case name -> (env id, config) of the observation-hash fixture."""
    out: dict[str, tuple[str, dict]] = {}
    for env_id, kind in cases():
        variants: list[dict] = [{"obs_format": "flat"}, {"obs_format": "dict"}, {"obs_format": "flat", "comm_dim": 2}]
        variants += [{"obs_format": "flat", **option} for option in OBS_OPTIONS.get(env_id, ())]
        if env_id == "Navigation-v0" and kind == "heading":
            variants += [{"obs_format": "flat", **scene} for scene in NAV_SCENES]
        for variant in variants:
            config = {"action_type": kind, **variant}
            out[f"{env_id}/{_label(config)}"] = (env_id, config)
    return out


def _random_value(space, mask, rng: np.random.Generator, env, key: str = ""):
    """A value of ``space`` from ``rng``: admissible under ``mask``; Rendezvous protocol messages hold a PRESENT record."""
    if hasattr(space, "spaces") and isinstance(space.spaces, dict):
        masks = mask if isinstance(mask, dict) else {}
        return {k: _random_value(sub, masks.get(k), rng, env, k) for k, sub in space.spaces.items()}
    if mask is not None:
        return int(rng.choice(np.flatnonzero(mask)))
    if hasattr(space, "n"):
        return int(rng.integers(space.start, space.start + space.n))
    if key == "message" and np.issubdtype(space.dtype, np.integer):
        from teamgym.envs.rendezvous.messages import Kind, encode

        return encode([(Kind.PRESENT, (int(rng.integers(len(env.place_index))),))], space.shape[0])
    return rng.uniform(space.low, space.high).astype(space.dtype)


def _feed_array(digest, value) -> None:
    array = np.ascontiguousarray(value)
    digest.update(f"{array.dtype.str}{array.shape}".encode())
    digest.update(array.tobytes())


def _feed_info(digest, key: str, value) -> None:
    if isinstance(value, str) or value is None:
        return
    if isinstance(value, dict):
        for sub in sorted(value):
            _feed_info(digest, f"{key}.{sub}", value[sub])
        return
    digest.update(key.encode())
    _feed_array(digest, np.asarray(value, dtype=np.float64))


def obs_hash(env_id: str, config: dict, seed: int, steps: int = OBS_STEPS) -> str:
    """SHA-256 of one seeded random rollout: observations, rewards, terminations, truncations, numeric infos."""
    env = teamgym.make(env_id, **config)
    digest = hashlib.sha256()
    rng = np.random.default_rng(seed)

    def feed(observations, infos, *tables) -> None:
        for agent in sorted(observations):
            digest.update(agent.encode())
            obs = observations[agent]
            for key in sorted(obs) if isinstance(obs, dict) else [""]:
                digest.update(key.encode())
                _feed_array(digest, obs[key] if key else obs)
        for table in tables:
            for agent in sorted(table):
                digest.update(agent.encode())
                _feed_array(digest, np.float64(table[agent]))
        for agent in sorted(infos):
            digest.update(agent.encode())
            for key in sorted(infos[agent]):
                _feed_info(digest, key, infos[agent][key])

    observations, infos = env.reset(seed=seed)
    feed(observations, infos)
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: _random_value(env.action_space(a), infos.get(a, {}).get("action_mask"), rng, env) for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        feed(observations, infos, rewards, terminations, truncations)
    return digest.hexdigest()


def record_obs_hashes() -> dict:
    """Every observation-hash case computed from the current code."""
    data: dict = {"steps": OBS_STEPS, "seeds": list(OBS_SEEDS), "cases": {}}
    for name, (env_id, config) in obs_cases().items():
        data["cases"][name] = {"env": env_id, "config": config, "hashes": [obs_hash(env_id, config, s) for s in OBS_SEEDS]}
        print(name, *(h[:12] for h in data["cases"][name]["hashes"]), flush=True)
    return data


def _obs_hashes_main(args: list[str]) -> None:
    data = record_obs_hashes()
    if args == ["--write"]:
        OBS_FIXTURE.parent.mkdir(parents=True, exist_ok=True)
        OBS_FIXTURE.write_text(json.dumps(data, indent=1) + "\n")
        print(f"wrote {OBS_FIXTURE}")
        return
    recorded = json.loads(OBS_FIXTURE.read_text())["cases"] if OBS_FIXTURE.exists() else {}
    differ = sorted(n for n in set(data["cases"]) | set(recorded) if data["cases"].get(n) != recorded.get(n))
    print(f"{len(differ)} case(s) differ from {OBS_FIXTURE.name}: {differ}" if differ else "all cases match the fixture")


USAGE = "usage: python -m tests.regression record | python -m tests.regression obs-hashes [--write]"

if __name__ == "__main__":
    if sys.argv[1:2] == ["obs-hashes"] and sys.argv[2:] in ([], ["--write"]):
        _obs_hashes_main(sys.argv[2:])
        sys.exit(0)
    if sys.argv[1:] != ["record"]:
        sys.exit(USAGE)
    FIXTURE.parent.mkdir(parents=True, exist_ok=True)
    existing = json.loads(FIXTURE.read_text()) if FIXTURE.exists() else None
    FIXTURE.write_text(json.dumps(record(existing), indent=1) + "\n")
