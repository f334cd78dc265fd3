"""What the Ray tests (test_rllib.py, test_ray_cluster.py) share: whether ray is installed, a tiny PPO iteration."""

import importlib.util

import pytest


def _importable(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except ImportError:  # the parent package is missing
        return False


HAVE_RAY = _importable("ray")
HAVE_RLLIB = HAVE_RAY and _importable("ray.rllib") and _importable("torch")
needs_rllib = pytest.mark.skipif(
    not HAVE_RLLIB, reason="needs ray[rllib]: pip install 'teamgym[rllib]' in its own venv (bash scripts/run_tests_rllib.sh)"
)
#: A tiny PPO iteration: 200 env steps (600 agent steps), two epochs of 3 minibatches.
TINY = {"train_batch_size_per_learner": 200, "minibatch_size": 200, "num_epochs": 2}
