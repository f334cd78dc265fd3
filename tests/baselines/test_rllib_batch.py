"""RLlib env runners stepping a ``teamgym.make_batch`` batch (``baselines.rl.rllib_batch``).

Marked ``rllib``: run by ``bash scripts/run_tests_rllib.sh`` in its own venv (ray[rllib] pins gymnasium 1.2.2).
The vector env must give RLlib exactly what RLlib's own ``SyncVectorMultiAgentEnv`` of
``TeamMultiAgentEnv`` copies gives with the same seeds and actions, through episode ends and auto-resets.
"""

import numpy as np
import pytest

from tests.rllib_support import TINY, needs_rllib

pytestmark = [pytest.mark.rllib, needs_rllib]

CASES = [
    ("Navigation-v0", {"max_cycles": 25}),
    ("Navigation-v0", {"max_cycles": 25, "action_type": "heading"}),
    ("BoxPushing-v0", {"max_cycles": 20}),
    ("Exploration-v0", {"max_cycles": 200, "action_type": "operator"}),
    ("Rendezvous-v0", {"max_cycles": 300}),
    ("Foraging-v0", {"max_cycles": 30}),
]


def _pair(env_id, config, n):
    from ray.rllib.env.vector.sync_vector_multi_agent_env import SyncVectorMultiAgentEnv

    from baselines.rl.rllib import TeamMultiAgentEnv
    from baselines.rl.rllib_batch import TeamVectorMultiAgentEnv

    spec = {"env_id": env_id, "config": config}
    sync = SyncVectorMultiAgentEnv([lambda: TeamMultiAgentEnv(spec) for _ in range(n)])  # noqa: B023 (spec is fixed)
    return sync, TeamVectorMultiAgentEnv(spec, n)


def _same(a, b, where):
    """``a`` and ``b`` equal value for value (dicts by key, sequences by item, arrays with dtype and shape)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{where}: keys {sorted(a)} != {sorted(b)}"
        for key in a:
            _same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, (list, tuple)):
        assert isinstance(b, (list, tuple)) and len(a) == len(b), f"{where}: {a!r} != {b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray) and a.dtype != object:
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, f"{where}: {a!r} vs {b!r}"
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), f"{where}: {a!r} != {b!r}"
    else:
        assert type(a) is type(b) and (a == b or a != a and b != b), f"{where}: {a!r} != {b!r}"


def _actions(vector, observations, rng):
    """A random admissible action for every agent that has an observation (masks from the observation)."""
    space = vector.single_action_spaces[vector.possible_agents[0]]
    out = []
    for obs in observations:
        acts = {}
        for agent, o in obs.items():
            if isinstance(o, dict):
                acts[agent] = int(rng.choice(np.flatnonzero(o["action_mask"])))
            elif hasattr(space, "n"):
                acts[agent] = int(rng.integers(space.n))
            else:
                acts[agent] = rng.uniform(space.low, space.high).astype(space.dtype)
        out.append(acts)
    return out


@pytest.mark.parametrize(("env_id", "config"), CASES, ids=[f"{e}-{c.get('action_type', 'default')}" for e, c in CASES])
def test_the_batch_vector_env_equals_rllibs_loop_over_copies(env_id, config):
    sync, vector = _pair(env_id, config, 3)
    rng = np.random.default_rng(0)
    obs_a, infos_a = sync.reset(seed=7)
    obs_b, infos_b = vector.reset(seed=7)
    _same(list(obs_a), obs_b, "reset observations")
    _same(list(infos_a), infos_b, "reset infos")
    ended = 0
    for t in range(80):
        actions = _actions(vector, obs_b, rng)
        out_a, out_b = sync.step(actions), vector.step(actions)
        for name, a, b in zip(("observations", "rewards", "terminations", "truncations", "infos"), out_a, out_b):
            _same(list(a), list(b), f"step {t} {name}")
        obs_b = out_b[0]
        ended += sum(flags["__all__"] for flags in out_b[2]) + sum(flags["__all__"] for flags in out_b[3])
    assert ended >= 1, "no copy reached its episode end: the auto-reset path was not exercised"
    sync.close()
    vector.close()


def test_a_missing_action_for_a_live_agent_is_one_line_error():
    _, vector = _pair("Navigation-v0", {}, 2)
    obs, _ = vector.reset(seed=0)
    actions = _actions(vector, obs, np.random.default_rng(0))
    del actions[1]["robot_0"]
    with pytest.raises(ValueError, match="copy 1 has no action for live agent 'robot_0'"):
        vector.step(actions)
    with pytest.raises(ValueError, match="2 copies"):
        vector.step(actions[:1])


def test_envs_per_runner_must_be_a_positive_integer():
    from baselines.rl.rllib import ppo_config

    with pytest.raises(ValueError, match="envs_per_runner must be an integer >= 1"):
        ppo_config("Navigation-v0", envs_per_runner=0)


def test_ppo_trains_on_batched_env_runners(tmp_path):
    import ray

    from baselines.rl.rllib import read_sidecar, train

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        out = train("Navigation-v0", 1, config={"max_cycles": 40}, out=tmp_path / "ckpt", training=TINY, envs_per_runner=4)
    finally:
        ray.shutdown()
    sidecar = read_sidecar(out)
    assert sidecar["envs_per_runner"] == 4
    (row,) = sidecar["history"]
    assert row["env_steps"] >= TINY["train_batch_size_per_learner"] and row["episodes"] >= 4
