"""Imitation (``baselines.rl.imitation``): expert actions in ``infos`` and behaviour cloning for PPO.

Small settings throughout: Navigation with two robots, a few hundred to a few thousand
expert transitions, and one 64-timestep PPO run for the command line.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import pickle

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import teamgym  # noqa: E402
from baselines.policy import Policy  # noqa: E402
from baselines.registry import _POLICIES, register_policy  # noqa: E402
from baselines.rl.imitation import (  # noqa: E402
    ExpertActions,
    behaviour_clone,
    collect_expert_data,
    collect_learner_data,
    make_expert,
    pretrain,
)
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.train import main as train_main  # noqa: E402

ENV_ARGS = ["--set", "n_robots=2", "--max-cycles", "10", "--n-envs", "1"]
PPO_ARGS = ["--hp", "n_steps=32", "--hp", "batch_size=32", "--hp", "n_epochs=2", "--verbose", "0"]


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


class GreedyForRandomness(Policy):
    """A misbehaving expert: draws from the env's generator and reseeds its action spaces."""

    name = "rng-eater"

    def reset(self, seed=None):
        super().reset(seed)
        for agent in self.env.possible_agents:
            self.env.action_space(agent).seed(123)

    def act(self, observations, infos=None):
        self.env.np_random.random(7)
        return {a: self.env.action_space(a).sample() for a in observations}


@pytest.fixture
def rng_eater():
    register_policy("rng-eater", f"{__name__}:GreedyForRandomness")
    yield "rng-eater"
    del _POLICIES["rng-eater"]


def without_expert(infos):
    return {a: {k: v for k, v in info.items() if k != "expert_action"} for a, info in infos.items()}


def assert_same_step(a, b):
    for got, want in zip(a[:4], b[:4]):
        assert got.keys() == want.keys()
        for agent in got:
            np.testing.assert_array_equal(got[agent], want[agent])
    assert repr(without_expert(a[4])) == repr(without_expert(b[4]))


@pytest.mark.parametrize("expert", ["goto", "rng-eater"])
def test_wrapper_does_not_change_the_trajectory(expert, rng_eater):
    plain = teamgym.make("Navigation-v0", n_robots=2, sensor_noise=0.01)  # noise: the sensors draw from np_random
    wrapped = ExpertActions(teamgym.make("Navigation-v0", n_robots=2, sensor_noise=0.01), expert)
    rng = np.random.default_rng(0)
    first = plain.reset(seed=5), wrapped.reset(seed=5)
    assert_same_step((first[0][0], {}, {}, {}, first[0][1]), (first[1][0], {}, {}, {}, first[1][1]))
    for owner in (plain, wrapped):  # the learner's own sampling must not be disturbed either
        for i, agent in enumerate(owner.possible_agents):
            owner.action_space(agent).seed(9 + i)
    for _ in range(40):
        if not plain.agents:
            break
        sampled = {a: plain.action_space(a).sample() for a in plain.agents}
        assert all(np.array_equal(sampled[a], wrapped.action_space(a).sample()) for a in wrapped.agents)
        actions = {a: rng.uniform(-0.4, 0.4, size=2).astype(np.float32) for a in plain.agents}
        assert_same_step(plain.step(actions), wrapped.step(actions))
        assert plain.np_random.bit_generator.state == wrapped.unwrapped.np_random.bit_generator.state


@pytest.mark.parametrize("action_type", ["velocity", "heading"])
def test_expert_action_for_every_live_agent_in_the_action_space(action_type):
    env = ExpertActions(teamgym.make("Navigation-v0", n_robots=3, action_type=action_type), "goto")
    observations, infos = env.reset(seed=1)
    steps = 0
    while env.agents:
        assert set(env.agents) <= set(infos)
        for agent, info in infos.items():
            if agent in env.agents:
                assert env.action_space(agent).contains(info["expert_action"]), info["expert_action"]
            else:
                assert "expert_action" not in info
        observations, _, _, _, infos = env.step({a: infos[a]["expert_action"] for a in env.agents})
        steps += 1
    assert steps < 400 and all("expert_action" not in info for info in infos.values())
    assert all(info["success"] for info in infos.values())  # following the labels is following goto


def test_wrapper_pickles_and_deep_copies_mid_episode():
    env = ExpertActions(teamgym.make("Navigation-v0", n_robots=2), "goto")
    env.reset(seed=2)
    for _ in range(5):
        _, _, _, _, infos = env.step({a: np.array([0.1, 0.5], np.float32) for a in env.agents})
    copies = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
    assert all(c.policy.env is c.unwrapped for c in copies)
    for _ in range(5):
        actions = {a: infos[a]["expert_action"] for a in env.agents}
        want = env.step(actions)
        for c in copies:
            got = c.step(actions)
            assert_same_step(got, want)
            for agent in want[4]:
                np.testing.assert_array_equal(got[4][agent]["expert_action"], want[4][agent]["expert_action"])
        infos = want[4]


def test_collected_returns_and_labels():
    data = collect_expert_data(teamgym.make("Navigation-v0", n_robots=2), "goto", 300, seed=0, gamma=0.9, noise=0.0)
    assert len(data) == 300 and data.observations.shape == (300, 33) and data.actions.shape == (300, 2)
    assert data.success_rate == 1.0 and np.isfinite(data.returns).all()
    again = collect_expert_data(teamgym.make("Navigation-v0", n_robots=2), "goto", 300, seed=0, gamma=0.9, noise=0.0)
    np.testing.assert_array_equal(data.observations, again.observations)
    noisy = collect_expert_data(teamgym.make("Navigation-v0", n_robots=2), "goto", 300, seed=0, gamma=0.9, noise=0.5)
    assert not np.array_equal(noisy.observations, data.observations)  # perturbed execution, expert labels


def make_model(action_type: str = "velocity"):
    from stable_baselines3 import PPO

    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", n_robots=2, action_type=action_type), n_envs=1)
    return PPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu"), venv


def split(data, fraction: float = 0.2, seed: int = 0):
    """``data`` without a random ``fraction`` of its transitions, and those held-out transitions."""
    order = np.random.default_rng(seed).permutation(len(data))
    cut = int(len(data) * fraction)
    part = lambda index: dataclasses.replace(  # noqa: E731
        data, observations=data.observations[index], actions=data.actions[index], returns=data.returns[index]
    )
    return part(order[cut:]), part(order[:cut])


def test_behaviour_cloning_matches_the_expert_on_held_out_observations():
    import torch

    data = collect_expert_data(teamgym.make("Navigation-v0", n_robots=2), "goto", 3000, seed=0, noise=0.5)
    train, held_out = split(data)
    model, venv = make_model()
    space = venv.action_space
    scale = held_out.actions.std(axis=0)  # errors in units of the expert's spread, per dimension

    def errors() -> np.ndarray:
        actions, _ = model.predict(held_out.observations, deterministic=True)
        return (np.abs(np.clip(actions, space.low, space.high) - held_out.actions) / scale).mean(axis=0)

    def value_error() -> float:
        with torch.no_grad():
            values = model.policy.predict_values(torch.as_tensor(held_out.observations)).numpy().ravel()
        return float(np.mean((values - held_out.returns) ** 2))

    before, before_value = errors(), value_error()
    stats = behaviour_clone(model, train, epochs=20, learning_rate=3e-3, seed=0)
    after = errors()
    assert after.mean() < 0.4 * before.mean() and np.all(after < 0.7 * before), (before, after)
    assert value_error() < 0.5 * before_value
    std = np.exp(model.policy.log_std.detach().numpy())
    np.testing.assert_allclose(std, stats["action_std"], rtol=1e-6)
    assert np.all(std >= 0.2 * space.high - 1e-6) and np.all(std < space.high)  # exploration kept, not SB3's std 1 on v
    venv.close()


def test_behaviour_cloning_of_discrete_actions():
    import torch

    env = teamgym.make("Navigation-v0", n_robots=2, action_type="heading")
    train, held_out = split(collect_expert_data(env, "goto", 2000, seed=0, noise=0.3))
    model, venv = make_model("heading")

    def accuracy_and_likelihood() -> tuple[float, float]:
        actions, _ = model.predict(held_out.observations, deterministic=True)
        with torch.no_grad():
            probabilities = model.policy.get_distribution(torch.as_tensor(held_out.observations)).distribution.probs.numpy()
        expert = probabilities[np.arange(len(held_out)), held_out.actions]
        return float(np.mean(actions == held_out.actions)), float(np.mean(expert))

    majority = np.bincount(held_out.actions).max() / len(held_out)  # always "straight on"
    before = accuracy_and_likelihood()
    behaviour_clone(model, train, epochs=20, learning_rate=3e-3, seed=0)
    after = accuracy_and_likelihood()
    assert after[0] > majority and after[1] > 2 * before[1], (majority, before, after)
    venv.close()


def test_dagger_data_follow_the_learner_and_carry_the_expert_labels():
    model, venv = make_model("heading")
    env = teamgym.make("Navigation-v0", n_robots=2, action_type="heading", max_cycles=30)
    data = collect_learner_data(env, model, "goto", 120, seed=7)
    assert len(data) == 120 and data.actions.dtype.kind == "i"
    # Replay the first episode: the states are the ones the learner's own (deterministic) actions lead
    # to, the labels goto's; rows come per agent (each agent's transitions in time order).
    replay = teamgym.make("Navigation-v0", n_robots=2, action_type="heading", max_cycles=30)
    expert = make_expert("goto", replay)
    observations, infos = replay.reset(seed=7)
    expert.reset(seed=7)
    tracks: dict[str, list] = {}
    learner_differs = False
    while replay.agents:
        live = list(replay.agents)
        labels = expert.act({a: observations[a] for a in live}, infos)
        actions, _ = model.predict(np.stack([observations[a] for a in live]), deterministic=True)
        for agent, action in zip(live, actions.tolist()):
            tracks.setdefault(agent, []).append((observations[agent], labels[agent]))
            learner_differs |= action != labels[agent]
        observations, _, _, _, infos = replay.step({a: int(x) for a, x in zip(live, actions)})
    rows = [row for track in tracks.values() for row in track]
    assert len(rows) < len(data)
    for k, (observation, label) in enumerate(rows):
        np.testing.assert_array_equal(data.observations[k], observation)
        assert data.actions[k] == label
    assert learner_differs, "the untrained learner happened to act like goto everywhere; the test shows nothing"
    merged = data.merged(data)
    assert len(merged) == 240 and merged.episodes == 2 * data.episodes
    venv.close()


def test_dagger_rounds_refit_on_the_aggregated_data():
    model, venv = make_model("heading")
    make = lambda: teamgym.make("Navigation-v0", n_robots=2, action_type="heading", max_cycles=30)  # noqa: E731
    record = pretrain(model, make, "goto", steps=150, epochs=2, seed=0, dagger_rounds=2, dagger_steps=100, dagger_epochs=1)
    assert record["dagger_rounds"] == 2 and record["dagger_transitions"] == 350
    assert len(record["dagger_learner_success"]) == 2 and np.isfinite(record["action_loss"])
    with pytest.raises(ValueError, match="dagger_rounds must be >= 0"):
        pretrain(model, make, "goto", steps=10, epochs=1, dagger_rounds=-1)
    venv.close()


def one_line_error(err: str, needle: str) -> None:
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert needle in err, err


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--bc-expert", "nope"], "unknown expert 'nope'"),
        (["--bc-expert", "sbs"], "policy 'sbs' does not fit Navigation-v0"),
        (["--bc-expert", "nash"], "--set action_type=heading"),
        (
            ["--bc-expert", "goto", "--algo", "sac"],
            "needs an actor-critic policy (ppo, a2c, maskable_ppo, recurrent_ppo or maskable_recurrent_ppo), not sac",
        ),
        (["--bc-steps", "100"], "need --bc-expert"),
        (["--bc-expert", "goto", "--bc-epochs", "0"], "--bc-epochs"),
        (["--bc-expert", "goto", "--resume", "somewhere.zip"], "cannot be combined with --resume"),
    ],
)
def test_command_line_errors(args, needle, tmp_path, capsys):
    assert train_main([*args, "--out", str(tmp_path / "m.zip")]) == 2
    one_line_error(capsys.readouterr().err, needle)
    assert not list(tmp_path.iterdir())


def test_sidecar_records_the_behaviour_cloning(tmp_path):
    bc = ["--bc-expert", "goto", "--bc-steps", "200", "--bc-epochs", "2"]
    evaluation = ["--eval-every", "64", "--eval-episodes", "2", "--eval-seed", "500"]
    out = tmp_path / "m.zip"
    assert train_main([*ENV_ARGS, *PPO_ARGS, *bc, *evaluation, "--timesteps", "64", "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    record = sidecar["bc"]
    assert (record["expert"], record["steps"], record["epochs"]) == ("goto", 200, 2)
    assert record["expert_episodes"] >= 1 and 0 <= record["expert_success_rate"] <= 1
    assert np.isfinite(record["action_loss"]) and len(record["action_std"]) == 2
    assert sidecar["trained_timesteps"] == 64  # the expert's transitions are not counted as training timesteps
    assert json.loads((tmp_path / "m_best.json").read_text())["bc"]["expert"] == "goto"
    plain = tmp_path / "p.zip"
    assert train_main([*ENV_ARGS, *PPO_ARGS, "--timesteps", "64", "--out", str(plain)]) == 0
    assert json.loads(plain.with_suffix(".json").read_text())["bc"] is None


@pytest.mark.parametrize("bad", [{"bc_dagger_steps": 0}, {"bc_dagger_epochs": 0}, {"bc_batch_size": 0}, {"bc_noise": 1.5}])
def test_invalid_dagger_and_fit_settings_are_refused_before_any_work(bad, tmp_path):
    from baselines.rl.train import train

    with pytest.raises(ValueError, match="bc_"):
        train("Navigation-v0", "ppo", 64, out=tmp_path / "m.zip", bc_expert="goto", bc_dagger=1, **bad)
    assert not list(tmp_path.iterdir())
