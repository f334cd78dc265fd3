"""The Ray RLlib path (``baselines.rl.rllib``) and ``baselines.evaluate --workers ray``.

Tests marked ``rllib`` need ``ray[rllib]``, which pins gymnasium 1.2.2: they run in their own
venv (``bash scripts/run_tests_rllib.sh``, CI's third step) on a local Ray cluster of 2 CPUs
and are skipped elsewhere. The tests without the marker check the one-line errors when ray
is missing and are skipped where it is installed.
"""

import json
import math

import numpy as np
import pytest
from gymnasium import spaces

import teamgym
from baselines import evaluate as evaluation
from baselines.summary import summarise
from tests.rllib_support import HAVE_RAY, HAVE_RLLIB, TINY, needs_rllib


@pytest.fixture(scope="module")
def ray_session():
    """One local Ray cluster (2 CPUs) for the module's tests."""
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


# -- without ray: one-line errors ----------------------------------------------------


@pytest.mark.skipif(HAVE_RAY, reason="ray is installed (this checks the error without it)")
def test_evaluate_workers_ray_without_ray_is_a_one_line_error(tmp_path, capsys):
    code = evaluation.main(["--episodes", "1", "--workers", "ray", "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("error: --workers ray needs the ray package")
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(HAVE_RLLIB, reason="ray[rllib] is installed (this checks the error without it)")
def test_rllib_cli_without_ray_is_a_one_line_error(capsys):
    from baselines.rl import rllib as rl

    assert rl.main(["--iterations", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "teamgym[rllib]" in err and "Traceback" not in err


def test_workers_must_be_a_count_or_ray(capsys):
    assert evaluation.main(["--workers", "rays"]) == 2
    assert "expected an integer >= 1 or 'ray'" in capsys.readouterr().err
    with pytest.raises(ValueError, match="'ray'"):
        evaluation.evaluate(workers="dask")


@pytest.mark.parametrize("address", ["auto", "127.0.0.1:6379", "[::1]:6379", "head-node.example:6379", "ray://head:10001"])
def test_a_ray_address_is_host_port_or_auto(address):
    assert evaluation.check_ray_address(address) == address


@pytest.mark.parametrize("address", ["", "local", "127.0.0.1", "127.0.0.1:0", "127.0.0.1:65536", "http://head:6379", "a b:1"])
def test_a_malformed_ray_address_is_refused(address):
    with pytest.raises(ValueError, match="HOST:PORT, ray://HOST:PORT or auto"):
        evaluation.check_ray_address(address)


def test_ray_address_errors_are_one_line_before_any_work(tmp_path, capsys):
    from baselines.rl import rllib as rl

    out = str(tmp_path / "out")
    assert evaluation.main(["--workers", "ray", "--ray-address", "head", "--out", out]) == 2
    assert evaluation.main(["--workers", "2", "--ray-address", "127.0.0.1:6379", "--out", out]) == 2
    assert rl.main(["--num-cpus", "2", "--ray-address", "127.0.0.1:6379", "--out", out]) == 2
    errors = capsys.readouterr().err.splitlines()
    assert len(errors) == 3 and "got 'head'" in errors[0]
    assert "--ray-address applies to --workers ray only, not --workers 2" in errors[1]
    assert "not allowed with argument" in errors[2]
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="workers='ray' only"):
        evaluation.evaluate(workers=2, ray_address="127.0.0.1:6379")


# -- the env adapter -------------------------------------------------------------------


class _TwoAgents:
    """A stub ParallelEnv whose last step ends one agent terminated and the other truncated."""

    possible_agents = ["a", "b"]
    _obs = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
    _act = spaces.Discrete(2)

    def __init__(self):
        self.agents = []

    def observation_space(self, agent):
        return self._obs

    def action_space(self, agent):
        return self._act

    def reset(self, seed=None, options=None):
        self.agents = list(self.possible_agents)
        return {a: np.zeros(2, np.float32) for a in self.agents}, {a: {} for a in self.agents}

    def step(self, actions):
        obs = {a: np.zeros(2, np.float32) for a in self.agents}
        self.agents = []
        return obs, {"a": 1.0, "b": 0.0}, {"a": True, "b": False}, {"a": False, "b": True}, {"a": {}, "b": {}}

    def close(self):
        pass


def _play(env, actions_of, seed):
    """One episode of ``env`` (a TeamMultiAgentEnv) recorded in RLlib's own MultiAgentEpisode."""
    from ray.rllib.env.multi_agent_episode import MultiAgentEpisode

    obs, infos = env.reset(seed=seed)
    episode = MultiAgentEpisode(
        observations=[obs], infos=[infos], observation_space=env.observation_spaces, action_space=env.action_spaces
    )
    while not episode.is_done:
        actions = actions_of(obs, infos)
        obs, rewards, terminateds, truncateds, infos = env.step(actions)
        episode.add_env_step(obs, actions, rewards, infos, terminateds=terminateds, truncateds=truncateds)
    return episode


@pytest.mark.rllib
@needs_rllib
def test_the_episode_ends_when_the_last_agents_end_terminated_and_truncated():
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    from baselines.rl.rllib import TeamMultiAgentEnv

    env = TeamMultiAgentEnv(env=_TwoAgents())
    env.reset(seed=0)
    _, _, terminateds, truncateds, _ = env.step({"a": 0, "b": 1})
    assert terminateds == {"a": True, "b": False, "__all__": False}
    assert truncateds == {"a": False, "b": False, "__all__": True}
    # RLlib's episode then ends with a terminated (no bootstrap) and b truncated (bootstrapped).
    episode = _play(env, lambda obs, infos: {"a": 0, "b": 1}, seed=0)
    a, b = episode.agent_episodes["a"], episode.agent_episodes["b"]
    assert (a.is_terminated, b.is_terminated, b.is_truncated) == (True, False, True)
    # RLlib's own wrapper ends this episode with both __all__ flags False (why the adapter exists).
    stock = ParallelPettingZooEnv(_TwoAgents())
    stock.reset(seed=0)
    _, _, terminateds, truncateds, _ = stock.step({"a": 0, "b": 1})
    assert not terminateds["__all__"] and not truncateds["__all__"]


@pytest.mark.rllib
@needs_rllib
def test_a_time_limit_is_a_truncation_for_every_agent_not_a_termination():
    from baselines.rl.rllib import TeamMultiAgentEnv

    env = TeamMultiAgentEnv({"env_id": "Navigation-v0", "config": {"max_cycles": 5}})
    episode = _play(env, lambda obs, infos: dict.fromkeys(obs, np.zeros(2, np.float32)), seed=0)
    assert episode.is_truncated and not episode.is_terminated
    for agent_episode in episode.agent_episodes.values():
        assert len(agent_episode) == 5 and agent_episode.is_truncated and not agent_episode.is_terminated


@pytest.mark.rllib
@needs_rllib
def test_agents_that_arrive_early_drop_out_of_an_rllib_episode():
    from baselines.registry import make_policy
    from baselines.rl.rllib import TeamMultiAgentEnv

    env = TeamMultiAgentEnv({"env_id": "Navigation-v0", "config": {"max_cycles": 60}})
    policy = make_policy("goto", env.env)
    for seed in range(10):
        policy.reset(seed)
        episode = _play(env, lambda obs, infos: policy.act({a: obs[a] for a in env.agents}, infos), seed)
        assert not env.agents and env.env.cycles <= 60
        agents = episode.agent_episodes
        assert set(agents) == set(env.possible_agents)
        lengths = {agent: len(agent_episode) for agent, agent_episode in agents.items()}
        early = [agent for agent, n in lengths.items() if n < env.env.cycles]
        late = [agent for agent, n in lengths.items() if n == 60]
        if early and late:  # some arrived, the others ran into the time limit
            assert all(agents[a].is_terminated and not agents[a].is_truncated for a in early)
            assert all(agents[a].is_terminated != agents[a].is_truncated for a in late)
            assert any(agents[a].is_truncated for a in late)  # bootstrapped, not a terminal state
            return
    pytest.fail("goto never brought one robot in before a 60-cycle time limit in 10 Navigation-v0 episodes")


@pytest.mark.rllib
@needs_rllib
def test_unsupported_spaces_are_refused_naming_the_space():
    from baselines.rl.rllib import TeamMultiAgentEnv

    with pytest.raises(ValueError, match="flat observations"):
        TeamMultiAgentEnv({"env_id": "Navigation-v0", "config": {"obs_format": "dict"}})
    with pytest.raises(ValueError, match="Box or Discrete actions"):
        TeamMultiAgentEnv({"env_id": "Navigation-v0", "config": {"comm_dim": 2}})


# -- training on a local Ray cluster ---------------------------------------------------


@pytest.mark.rllib
@needs_rllib
def test_one_ppo_iteration_trains_the_one_shared_module(ray_session):
    import torch

    from baselines.rl.rllib import MODULE_ID, ppo_config

    algo = ppo_config("Navigation-v0", {"max_cycles": 50}, seed=0, training=TINY).build_algo()
    try:
        module = algo.get_module(MODULE_ID)
        before = {k: v.clone() for k, v in module.state_dict().items()}
        result = algo.train()
        after = algo.get_module(MODULE_ID).state_dict()
        assert set(algo.config.policies) == {MODULE_ID}
    finally:
        algo.stop()
    assert result["num_env_steps_sampled_lifetime"] >= 200
    per_agent = result["env_runners"]["num_agent_steps_sampled_lifetime"]
    assert set(per_agent) == {"robot_0", "robot_1", "robot_2"}  # every robot fed the one module
    trained = result["learners"][MODULE_ID]
    assert trained["num_module_steps_trained"] >= sum(per_agent.values())
    assert math.isfinite(trained["total_loss"]) and math.isfinite(result["env_runners"]["episode_return_mean"])
    changed = [k for k in before if not torch.equal(before[k], after[k])]
    assert changed, "one iteration changed no weight"
    shapes = {tuple(v.shape) for v in after.values()}
    assert {(64, 38), (64, 64), (1, 64)} <= shapes  # 64-64 tanh networks on Navigation's 38 inputs, a value head
    assert not any(256 in shape for shape in shapes)  # not RLlib's default 256-256


@pytest.mark.rllib
@needs_rllib
def test_cli_trains_saves_and_evaluates_a_checkpoint(ray_session, tmp_path, capsys):
    from baselines.rl import rllib as rl

    out = tmp_path / "nav"
    hp = [f"--hp={k}={v}" for k, v in TINY.items()]
    argv = ["--env", "Navigation-v0", "--iterations", "1", "--set", "max_cycles=50", *hp, "--out", str(out)]
    assert rl.main([*argv, "--eval-episodes", "2", "--eval-seed", "100"]) == 0
    printed = capsys.readouterr().out
    assert "iteration 1:" in printed and f"saved {out}" in printed
    sidecar = json.loads((out / "teamgym.json").read_text())
    assert sidecar["format"] == 1 and sidecar["engine"] == "rllib" and sidecar["algo"] == "ppo"
    assert sidecar["env"] == "Navigation-v0" and sidecar["overrides"] == {"max_cycles": "50"}
    assert sidecar["config"]["max_cycles"] == 50 and sidecar["config"]["n_robots"] == 3  # the resolved config
    assert sidecar["training"]["lr"] == rl.TESTED_SETTINGS["lr"] and sidecar["training"]["num_epochs"] == 2
    assert sidecar["model"]["fcnet_hiddens"] == [64, 64] and sidecar["model"]["vf_share_layers"] is False
    (row,) = sidecar["history"]
    assert row["env_steps"] >= 200 and row["agent_steps"] >= 3 * 200 - 3 and row["episodes"] >= 3
    assert sidecar["eval"]["episodes"] == 2 and sidecar["eval"]["mean_episode_length"] == 50
    assert rl.module_path(out).is_dir()

    # the saved module acts for every robot within the action bounds, deterministically
    env = teamgym.make("Navigation-v0", max_cycles=50)
    policy = rl.RLlibPolicy(env, out)
    obs, infos = env.reset(seed=3)
    first, again = policy.act(obs, infos), policy.act(obs, infos)
    space = env.action_space("robot_0")
    assert set(first) == set(env.agents)
    for agent, action in first.items():
        assert space.contains(action) and np.array_equal(action, again[agent])
    results = rl.evaluate_checkpoint(out, "Navigation-v0", {"max_cycles": 50}, episodes=2, seed=100)
    assert summarise(results)["mean_return"] == pytest.approx(sidecar["eval"]["mean_return"])

    # the evaluation CLI plays the checkpoint as rllib:PATH, env and config from its sidecar
    cli = ["--policy", f"rllib:{out}", "--episodes", "2", "--seed", "100", "--out", str(tmp_path / "ev"), "--quiet"]
    assert evaluation.main([*cli, "--no-plot"]) == 0
    written = json.loads((tmp_path / "ev" / "summary.json").read_text())
    assert written["env"] == "Navigation-v0" and written["overrides"] == {"max_cycles": "50"}
    assert written["sidecar"] == str(out / "teamgym.json") and written["deterministic"] is True
    assert written["mean_return"] == pytest.approx(sidecar["eval"]["mean_return"])

    # a bad setting is one line, before anything trains
    assert rl.main([*argv, "--hp", "lrr=1"]) == 2
    assert rl.main(["--set", "n_robots=0", "--iterations", "1", "--out", str(tmp_path / "bad")]) == 2
    errors = capsys.readouterr().err.splitlines()
    assert len(errors) == 2 and "'lrr' is not a PPOConfig.training keyword" in errors[0] and "n_robots" in errors[1]
    assert not (tmp_path / "bad").exists()


@pytest.mark.rllib
@needs_rllib
def test_masked_discrete_actions_train_and_act_admissibly(ray_session, tmp_path):
    from baselines.rl import rllib as rl

    # Foraging-v0's go-to cells are masked; the env raises on an inadmissible action, so a
    # finished iteration means every sampled action was admissible.
    out = rl.train("Foraging-v0", 1, config={"max_cycles": 40}, out=tmp_path / "forage", training=TINY)
    assert rl.read_sidecar(out)["history"][0]["env_steps"] >= 200
    env = teamgym.make("Foraging-v0", max_cycles=40)
    policy = rl.RLlibPolicy(env, out)
    obs, infos = env.reset(seed=1)
    for _ in range(5):
        actions = policy.act({a: obs[a] for a in env.agents}, infos)
        masks = env.action_masks()
        assert all(masks[a][actions[a]] for a in actions)
        obs, _, _, _, infos = env.step(actions)


# -- evaluate --workers ray --------------------------------------------------------------


@pytest.mark.rllib
@needs_rllib
def test_a_ray_address_beside_a_running_session_or_num_cpus_is_refused(ray_session, tmp_path, capsys):
    from baselines.rl import rllib as rl

    with pytest.raises(ValueError, match="already runs a Ray session"):
        evaluation.evaluate(episodes=2, workers="ray", ray_address="127.0.0.1:6379")
    with pytest.raises(ValueError, match="already runs a Ray session"):
        rl.train(iterations=1, out=tmp_path / "a", ray_address="127.0.0.1:6379")
    with pytest.raises(ValueError, match="cannot be given with ray_address"):
        rl.train(iterations=1, out=tmp_path / "b", ray_address="127.0.0.1:6379", num_cpus=2)
    assert rl.main(["--evaluate", str(tmp_path / "c"), "--ray-address", "127.0.0.1:6379"]) == 2
    assert "--ray-address applies to training" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.rllib
@needs_rllib
def test_evaluate_on_ray_equals_one_worker(ray_session, tmp_path):
    kwargs = {"episodes": 5, "seed": 7, "config": {"max_cycles": 120}, "keep_trajectories": True}
    sequential = evaluation.evaluate("Navigation-v0", "goto", workers=1, **kwargs)
    on_ray = evaluation.evaluate("Navigation-v0", "goto", workers="ray", **kwargs)
    assert [r.seed for r in on_ray] == list(range(7, 12))
    assert on_ray == sequential
    assert len({r.mean_return for r in on_ray}) > 1  # different episodes, not one repeated
    assert ray_session.is_initialized()  # a session it did not start is left running

    common = ["--env", "Navigation-v0", "--policy", "goto", "--episodes", "4", "--max-cycles", "120", "--quiet", "--no-plot"]
    assert evaluation.main([*common, "--workers", "ray", "--out", str(tmp_path / "ray")]) == 0
    assert evaluation.main([*common, "--workers", "1", "--out", str(tmp_path / "one")]) == 0
    assert (tmp_path / "ray" / "episodes.csv").read_text() == (tmp_path / "one" / "episodes.csv").read_text()
    ray_summary = json.loads((tmp_path / "ray" / "summary.json").read_text())
    one_summary = json.loads((tmp_path / "one" / "summary.json").read_text())
    assert ray_summary.pop("workers") == "ray" and one_summary.pop("workers") == 1
    (node,) = [n["NodeID"] for n in ray_session.nodes() if n["Alive"]]
    assert ray_summary.pop("ray_nodes") == {node: 4} and "ray_nodes" not in one_summary
    assert ray_summary == one_summary
