"""Observation hashes of every env are those of the fixture recorded before the speed work (issue 15).

``tests/data/obs_hashes.json`` covers every registered env, action type and ``obs_format``,
the learned message, the tasks' observation options and the ``nash`` Navigation settings
(see :mod:`regression`). It is regenerated only on purpose, by
``python -m tests.regression obs-hashes --write``; this test never writes it.
"""

import json

import pytest
from regression import OBS_FIXTURE, OBS_SEEDS, OBS_STEPS, obs_cases, obs_hash

RECORDED = json.loads(OBS_FIXTURE.read_text())
CASES = obs_cases()


def test_fixture_covers_every_case():
    assert sorted(CASES) == sorted(RECORDED["cases"])
    assert (RECORDED["steps"], tuple(RECORDED["seeds"])) == (OBS_STEPS, OBS_SEEDS)


@pytest.mark.parametrize("name", sorted(CASES))
def test_rollout_hashes_match_the_fixture(name: str) -> None:
    env_id, config = CASES[name]
    case = RECORDED["cases"][name]
    assert (case["env"], case["config"]) == (env_id, config)
    for seed, recorded in zip(OBS_SEEDS, case["hashes"], strict=True):
        assert obs_hash(env_id, config, seed) == recorded, f"{name} seed {seed} differs from the recorded rollout"
