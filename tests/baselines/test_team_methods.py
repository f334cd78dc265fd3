"""``baselines.train --critic central / --agent-id / --independent``: the widened observations, the
centralised critic, the independent policies, their sidecar, and train → save → ``evaluate --policy
sb3:`` giving training's own evaluation figures (Navigation-v0 and the masked Rendezvous-v0).

Every training here is tiny: rollouts of 32 steps on one env copy of two robots, 128 timesteps.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import torch as th  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

import teamgym  # noqa: E402
from baselines.rl.agent_features import FeatureSB3Policy, FeatureTeamVecEnv, ObservationFeatures  # noqa: E402
from baselines.rl.central_critic import CentralCriticPolicy, MaskableCentralCriticPolicy  # noqa: E402
from baselines.rl.independent import IndependentPolicy, MaskableIndependentPolicy, member  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy, algorithm_class  # noqa: E402
from baselines.rl.team_methods import TeamMethods  # noqa: E402
from baselines.train import main as train_main  # noqa: E402
from tests.train_support import evaluate_matches_training  # noqa: E402

PPO_ARGS = ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=2", "--verbose", "0", "--n-envs", "1"]
EVAL_ARGS = ["--eval-every", "64", "--eval-episodes", "3", "--eval-seed", "500"]
#: (env id, overrides, algorithm): a continuous env and a masked discrete one
ENVS = [
    ("Navigation-v0", {"n_robots": "2", "max_cycles": "10"}, "ppo"),
    ("Rendezvous-v0", {"max_cycles": "20"}, "maskable_ppo"),
]
METHODS = [["--critic", "central"], ["--agent-id"], ["--independent"], ["--independent", "--critic", "central"]]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def set_args(overrides: dict[str, str]) -> list[str]:
    return [arg for key, value in overrides.items() for arg in ("--set", f"{key}={value}")]


def one_line_error(err: str, needle: str) -> None:
    assert err.startswith("error: "), err
    assert len(err.strip().splitlines()) == 1, err
    assert needle in err, err


@pytest.mark.parametrize("env_id,overrides,algo", ENVS, ids=[e[0] for e in ENVS])
@pytest.mark.parametrize("methods", METHODS, ids=["central", "agent-id", "independent", "independent-central"])
def test_train_save_and_evaluate_give_the_same_figures(env_id, overrides, algo, methods, tmp_path):
    out = tmp_path / "m.zip"
    args = ["--env", env_id, "--algo", algo, "--timesteps", "128", *set_args(overrides), *PPO_ARGS, *EVAL_ARGS]
    assert train_main([*args, *methods, "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    central, independent = "central" in methods, "--independent" in methods
    assert sidecar["critic"] == ("central" if central else "local") and sidecar["independent"] is independent
    assert sidecar["agent_id"] is ("--agent-id" in methods)
    assert sidecar["obs_features"] == {"agent_id": "--agent-id" in methods or independent, "team_state": central}
    assert TeamMethods.from_sidecar(sidecar).features.sidecar() == sidecar["obs_features"]

    env = teamgym.make(env_id, **{k: int(v) for k, v in overrides.items()})
    policy = SB3Policy.load(out, env)
    assert isinstance(policy, FeatureSB3Policy) and policy.algo == algo
    maskable = algo == "maskable_ppo"
    want = {
        (False, False): type(None),
        (True, False): MaskableCentralCriticPolicy if maskable else CentralCriticPolicy,
        (False, True): MaskableIndependentPolicy if maskable else IndependentPolicy,
        (True, True): MaskableIndependentPolicy if maskable else IndependentPolicy,
    }[central, independent]
    if want is not type(None):
        assert type(policy.model.policy) is want
    width = env.observation_space(env.possible_agents[0]).shape[0]
    width += len(env.possible_agents) * policy.features.agent_id + env.state_space.shape[0] * policy.features.team_state
    assert policy.model.observation_space.shape == (width,)

    last, summary = evaluate_matches_training(out, 3, 500, tmp_path / "eval")
    assert int(last["timesteps"]) == sidecar["trained_timesteps"]
    assert summary["config"]["max_cycles"] == int(overrides["max_cycles"])


def venv_and_model(env_id: str, algo: str, methods: TeamMethods, **config):
    env = teamgym.make(env_id, **config)
    policy, kwargs = methods.policy(algo, env)
    venv = methods.make_venv(lambda: teamgym.make(env_id, **config), n_envs=1)
    model = algorithm_class(algo)(policy, venv, n_steps=16, batch_size=16, policy_kwargs=kwargs, seed=0, device="cpu")
    return env, venv, model


@pytest.mark.parametrize("env_id,algo", [("Navigation-v0", "ppo"), ("Rendezvous-v0", "maskable_ppo")])
def test_the_critic_reads_the_state_and_the_actor_does_not(env_id, algo):
    env, venv, model = venv_and_model(env_id, algo, TeamMethods(critic="central"))
    own, state = env.observation_space(env.possible_agents[0]).shape[0], env.state_space.shape[0]
    extractor = model.policy.mlp_extractor
    assert extractor.value_net[0].in_features == own + state  # critic: observation and team state
    assert extractor.policy_net[0].in_features == own  # actor: the observation alone
    obs = th.as_tensor(venv.reset())
    assert th.allclose(obs[0, own:], th.as_tensor(venv.envs[0].state(), dtype=th.float32))
    changed = obs.clone()
    changed[:, own:] += th.linspace(1.0, 3.0, state)
    with th.no_grad():
        values, values_changed = model.policy.predict_values(obs), model.policy.predict_values(changed)
        dist, dist_changed = model.policy.get_distribution(obs), model.policy.get_distribution(changed)
    assert not th.allclose(values, values_changed)
    if algo == "ppo":
        assert th.equal(dist.distribution.mean, dist_changed.distribution.mean)
        assert th.equal(dist.distribution.stddev, dist_changed.distribution.stddev)
    else:
        assert th.equal(dist.distribution.probs, dist_changed.distribution.probs)
    venv.close()


EVERY_ENV = [(env_id, {}) for env_id in teamgym.envs()] + [("Exploration-v0", {"action_type": "operator"})]


@pytest.mark.parametrize("env_id,config", EVERY_ENV, ids=[f"{e}{'-' if c else ''}{'-'.join(c.values())}" for e, c in EVERY_ENV])
def test_central_critic_trains_on_every_env(env_id, config):
    probe = teamgym.make(env_id, **config)
    masked = getattr(probe.action_type, "has_masks", False)
    algo = "maskable_ppo" if masked else "ppo"
    env, venv, model = venv_and_model(env_id, algo, TeamMethods(critic="central"), max_cycles=8, **config)
    assert (
        model.observation_space.shape[0]
        == probe.observation_space(probe.possible_agents[0]).shape[0] + probe.state_space.shape[0]
    )
    model.learn(total_timesteps=16 * venv.num_envs)
    assert model.num_timesteps >= 16 * venv.num_envs
    venv.close()


def test_slots_carry_their_robot_index_and_their_copy_state():
    features = ObservationFeatures(agent_id=True, team_state=True)
    make = lambda: teamgym.make("Navigation-v0", n_robots=3, max_cycles=12)  # noqa: E731
    wide, plain = FeatureTeamVecEnv(make, n_envs=2, features=features), TeamVecEnv(make, n_envs=2)
    assert wide.batched and wide.observation_space.shape == (38 + 3 + 29,)
    wide.seed(7), plain.seed(7)
    obs, base = wide.reset(), plain.reset()
    rng = np.random.default_rng(0)
    finished = 0
    for _ in range(15):
        for k in range(wide.num_envs):
            row = int(wide._slot_row[k])
            if row < 0:
                assert not obs[k].any()  # a waiting slot: zeros
                continue
            assert np.array_equal(obs[k, :38], base[k])
            assert np.array_equal(obs[k, 38:41], np.eye(3)[row])
            assert np.array_equal(obs[k, 41:], wide.envs[wide._copy_of[k]].state())
        actions = rng.uniform(-1, 1, size=(wide.num_envs, 2)).astype(np.float32)
        wide.step_async(actions), plain.step_async(actions)
        (obs, _, _, infos), (base, _, _, plain_infos) = wide.step_wait(), plain.step_wait()
        for info, plain_info in zip(infos, plain_infos):
            if "terminal_observation" in info:
                finished += 1
                assert info["terminal_observation"].shape == (70,)
                assert np.array_equal(info["terminal_observation"][:38], plain_info["terminal_observation"])
    assert finished >= 6  # every robot's episode ended (max_cycles=12) and its terminal observation was widened
    wide.close(), plain.close()


def test_independent_members_share_no_parameters():
    env, venv, model = venv_and_model("Navigation-v0", "ppo", TeamMethods(independent=True), n_robots=2, max_cycles=10)
    policy = model.policy
    assert isinstance(policy, IndependentPolicy) and len(policy.members) == 2
    first, second = member(policy, 0), member(policy, 1)
    assert not {id(p) for p in first.parameters()} & {id(p) for p in second.parameters()}
    assert {id(p) for g in policy.optimizer.param_groups for p in g["params"]} == {id(p) for p in policy.parameters()}
    obs = th.as_tensor(venv.reset())
    index = policy.robot_index(obs)
    assert index.tolist() == [0, 1]
    with th.no_grad():  # each row is its own robot's member
        values = policy.predict_values(obs)
        assert th.equal(values[0], first.predict_values(obs[:1])[0]) and th.equal(values[1], second.predict_values(obs[1:])[0])
    actions = th.zeros((1, 2))
    values, log_prob, entropy = policy.evaluate_actions(obs[:1], actions)  # robot 0's row only
    (values.sum() + log_prob.sum() + entropy.sum()).backward()
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in first.mlp_extractor.parameters())
    assert all(p.grad is None for p in second.parameters())  # robot 1's networks learn nothing from robot 0
    venv.close()


def test_a_saved_independent_model_reloads_every_member(tmp_path):
    env, venv, model = venv_and_model("Navigation-v0", "ppo", TeamMethods(independent=True), n_robots=2, max_cycles=10)
    model.save(str(tmp_path / "m.zip"))
    loaded = PPO.load(str(tmp_path / "m.zip"), device="cpu")
    assert type(loaded.policy) is IndependentPolicy and loaded.policy.n_agents == 2
    a, b = model.policy.state_dict(), loaded.policy.state_dict()
    assert set(a) == set(b) and any(k.startswith("members.1.") for k in a) and all(th.equal(a[k], b[k]) for k in a)
    venv.close()


def test_sidecar_round_trip_and_bad_records():
    for methods in (TeamMethods(), TeamMethods("central"), TeamMethods(agent_id=True), TeamMethods("central", True, True)):
        assert TeamMethods.from_sidecar(methods.sidecar()) == methods
        features = methods.features
        assert ObservationFeatures.from_sidecar({"obs_features": methods.sidecar()["obs_features"]}) == features
    assert ObservationFeatures.from_sidecar({}) == ObservationFeatures()
    with pytest.raises(ValueError, match="obs_features"):
        ObservationFeatures.from_sidecar({"obs_features": {"agent_id": "yes"}})


NAV = ["--timesteps", "64", "--set", "n_robots=2", "--max-cycles", "5", "--verbose", "0"]


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--critic", "central", "--algo", "dqn", "--set", "action_type=heading"], "has none"),
        (["--independent", "--algo", "sac"], "--independent needs an actor-critic"),
        (["--env", "BoxPushing-v0", "--set", "n_spare_robots=1", "--independent", "--timesteps", "64"], "fixed team"),
        (["--agent-id", "--bc-expert", "nash"], "--bc-expert"),
        (["--critic", "central", "--workers", "2", "--n-envs", "2"], "--workers"),
        (["--critic", "cental"], "invalid choice"),
        (["--agent-id", "--set", "obs_format=dict"], "flat Box observations"),
        (["--agent-id", "--algo", "recurrent-ppo"], "does not take them yet"),
    ],
    ids=["dqn-central", "sac-independent", "spare-robots", "bc", "workers", "typo", "dict-obs", "recurrent"],
)
def test_bad_combinations_are_one_line_errors_before_any_work(args, needle, tmp_path, capsys):
    out = tmp_path / "m.zip"
    base = NAV if "--env" not in args else ["--verbose", "0"]
    assert train_main([*base, *args, "--out", str(out)]) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_resume_keeps_the_methods_and_refuses_others(tmp_path, capsys):
    out = tmp_path / "m.zip"
    assert train_main([*NAV, *PPO_ARGS, "--critic", "central", "--out", str(out)]) == 0
    assert train_main(["--resume", str(out), "--timesteps", "32", "--critic", "local", "--verbose", "0"]) == 2
    one_line_error(capsys.readouterr().err, "critic='central'")
    assert train_main(["--resume", str(out), "--timesteps", "32", "--verbose", "0"]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["critic"] == "central" and sidecar["trained_timesteps"] > 64
    assert isinstance(SB3Policy.load(out, teamgym.make("Navigation-v0", n_robots=2)), FeatureSB3Policy)


def test_plain_runs_record_the_default_methods(tmp_path):
    out = tmp_path / "m.zip"
    assert train_main([*NAV, *PPO_ARGS, "--out", str(out)]) == 0
    sidecar = json.loads(Path(out.with_suffix(".json")).read_text())
    assert sidecar["critic"] == "local" and sidecar["obs_features"] is None
    assert type(SB3Policy.load(out, teamgym.make("Navigation-v0", n_robots=2))) is SB3Policy


def random_actions(venv, rng):
    if getattr(venv.envs[0].action_type, "has_masks", False):
        return np.array([rng.choice(np.flatnonzero(row)) for row in venv.action_masks()])
    return np.stack([venv.action_space.sample() for _ in range(venv.num_envs)])


@pytest.mark.parametrize("env_id", teamgym.envs())
def test_batched_and_one_by_one_copies_give_the_same_widened_observations(env_id):
    """Both stepping paths, terminal observations included, and each slot as ``ObservationFeatures.widen`` builds it."""
    features = ObservationFeatures(agent_id=True, team_state=True)
    runs = []
    for batched in (True, False):
        venv = FeatureTeamVecEnv(lambda: teamgym.make(env_id, max_cycles=10), n_envs=2, batched=batched, features=features)
        assert venv.batched is batched
        venv.seed(3)
        venv.action_space.seed(0)
        rng = np.random.default_rng(0)
        observations, terminals = [venv.reset()], []
        for _ in range(25):
            expected = np.zeros_like(observations[-1])
            for k in range(venv.num_envs):
                row, e = int(venv._slot_row[k]), venv._copy_of[k]
                if row >= 0:
                    expected[k] = features.widen(venv._obs[k], row, venv.agents_per_env, venv.envs[e].state)
            assert np.array_equal(observations[-1], expected)
            venv.step_async(random_actions(venv, rng))
            obs, _, _, infos = venv.step_wait()
            observations.append(obs)
            terminals += [(k, info["terminal_observation"]) for k, info in enumerate(infos) if "terminal_observation" in info]
        runs.append((np.array(observations), terminals))
        venv.close()
    (first, first_terminals), (second, second_terminals) = runs
    assert np.array_equal(first, second)
    assert len(first_terminals) == len(second_terminals) > 0
    assert all(a == c and np.array_equal(b, d) for (a, b), (c, d) in zip(first_terminals, second_terminals))


def test_widened_observations_with_learned_messages_train_save_and_evaluate_alike(tmp_path):
    """--agent-id and --critic central beside a motion ⊕ message action (comm_dim): the codec and the widening compose."""
    out = tmp_path / "m.zip"
    overrides = {"n_robots": "2", "max_cycles": "10", "comm_dim": "2"}
    args = ["--env", "Navigation-v0", "--timesteps", "128", *set_args(overrides), *PPO_ARGS, *EVAL_ARGS]
    assert train_main([*args, "--agent-id", "--critic", "central", "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["message_actions"] and sidecar["obs_features"] == {"agent_id": True, "team_state": True}
    env = teamgym.make("Navigation-v0", n_robots=2, max_cycles=10, comm_dim=2)
    policy = SB3Policy.load(out, env)
    assert isinstance(policy, FeatureSB3Policy) and policy.codec is not None
    observations, infos = env.reset(seed=500)
    actions = policy.act(observations, infos)
    assert all(env.action_space(agent).contains(action) for agent, action in actions.items())
    evaluate_matches_training(out, 3, 500, tmp_path / "eval")
