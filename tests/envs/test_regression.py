"""The flat observations, rewards and infos of every env and action type match the recorded fixture.

The fixture (``tests/data/regression_hashes.json``) was recorded by ``python -m tests.regression
record`` before the core refactor; see :mod:`regression` for what a fingerprint covers.
"""

import json

import pytest
from regression import FIXTURE, SEEDS, cases, fingerprint

RECORDED = json.loads(FIXTURE.read_text())


def test_fixture_covers_every_env_and_action_type():
    assert sorted(f"{e}/{k}" for e, k in cases()) == sorted(RECORDED["cases"])


@pytest.mark.parametrize(("env_id", "action_type"), cases())
def test_flat_observations_reproduce_recorded_rollouts(env_id, action_type):
    case = RECORDED["cases"][f"{env_id}/{action_type}"]
    for seed in SEEDS:
        digest, _ = fingerprint(env_id, action_type, seed, case["info_keys"], obs_format="flat")
        assert digest == case["hashes"][seed], f"{env_id} {action_type} seed {seed} differs from the recorded rollout"
