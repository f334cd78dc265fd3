"""Behaviour cloning into recurrent policies: sequences per robot-episode, LSTM states carried across segments."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

from sb3_contrib import RecurrentPPO  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv  # noqa: E402

from baselines.rl.imitation import ExpertData, behaviour_clone, collect_learner_data  # noqa: E402
from baselines.rl.recurrent_imitation import behaviour_clone_recurrent, segments_of  # noqa: E402
from baselines.train import main as train_main  # noqa: E402


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


class _Cue(gym.Env):
    """Observation (cue, clock): the cue ±1 only at the first step, 0 after; the spaces the synthetic data use."""

    def __init__(self, action_space: gym.Space) -> None:
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.action_space = action_space

    def reset(self, *, seed=None, options=None):
        return np.zeros(2, np.float32), {}

    def step(self, action):
        return np.zeros(2, np.float32), 0.0, True, False, {}


def cue_data(episodes: int, length: int, discrete: bool, seed: int = 0) -> ExpertData:
    """Episodes whose label at every step is the cue shown at the first step only: it must be remembered."""
    rng = np.random.default_rng(seed)
    observations, actions, starts = [], [], []
    for _ in range(episodes):
        cue = float(rng.choice([-1.0, 1.0]))
        for t in range(length):
            observations.append([cue if t == 0 else 0.0, t / length])
            actions.append((1 if cue > 0 else 0) if discrete else [0.8 * cue])
            starts.append(t == 0)
    n = len(observations)
    return ExpertData(
        observations=np.array(observations, np.float32),
        actions=np.array(actions),
        returns=np.zeros(n, np.float32),
        episodes=episodes,
        success_rate=1.0,
        mean_return=0.0,
        starts=np.array(starts),
    )


def recurrent_model(action_space: gym.Space, seed: int = 0) -> RecurrentPPO:
    venv = DummyVecEnv([lambda: _Cue(action_space)])
    small = {"lstm_hidden_size": 16}
    return RecurrentPPO("MlpLstmPolicy", venv, n_steps=8, batch_size=8, seed=seed, device="cpu", policy_kwargs=small)


def replay(model: RecurrentPPO, data: ExpertData) -> np.ndarray:
    """Deterministic actions of ``model`` run over each episode of ``data`` from a zero state, step by step."""
    actions, state = [], None
    for observation, start in zip(data.observations, data.starts):
        action, state = model.predict(observation[None], state=state, episode_start=np.array([start]), deterministic=True)
        actions.append(action[0])
    return np.array(actions)


def test_segments_cover_every_transition_once_and_never_cross_an_episode():
    starts = np.array([True, False, False, False, False, True, False, True])
    segments = segments_of(starts, 2)
    covered = segments.index[segments.index >= 0]
    assert sorted(covered.tolist()) == list(range(8))
    assert segments.count == 3
    assert segments.index.tolist() == [[0, 1], [2, 3], [4, -1], [5, 6], [7, -1]]
    assert segments.episode.tolist() == [0, 0, 0, 1, 2] and segments.position.tolist() == [0, 1, 2, 0, 0]


@pytest.mark.parametrize("discrete", [False, True], ids=["box", "discrete"])
def test_a_cue_seen_once_is_carried_through_later_segments(discrete):
    """Labels that depend on the first observation only: a clone fitted on sequences recalls it 150 steps on.

    Episodes of 150 steps in segments of 64: the later segments start from the state the burn-in
    pass carries over, not from zeros (with zeros they could not know the cue).
    """
    space = gym.spaces.Discrete(2) if discrete else gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    data = cue_data(episodes=24, length=150, discrete=discrete)
    model = recurrent_model(space)
    stats = behaviour_clone(model, data, 40, batch_size=512, learning_rate=3e-3, fit_value=False)
    assert stats["sequence_length"] == 64
    held_out = cue_data(episodes=6, length=150, discrete=discrete, seed=1)
    predicted, expected = replay(model, held_out).reshape(-1), held_out.actions.reshape(-1)
    late = np.arange(len(held_out)) % 150 >= 64  # steps in the second and third segments
    if discrete:
        assert (predicted == expected).mean() > 0.97 and (predicted[late] == expected[late]).mean() > 0.95
    else:
        assert np.all(np.sign(predicted[late]) == np.sign(expected[late]))


def test_without_starts_recurrent_cloning_is_refused():
    data = cue_data(episodes=2, length=10, discrete=True)
    data.starts = None
    with pytest.raises(ValueError, match="episode starts"):
        behaviour_clone_recurrent(recurrent_model(gym.spaces.Discrete(2)), data, 1)


def test_dagger_with_a_recurrent_learner_carries_each_robots_state(monkeypatch):
    """The learner drives with each robot's LSTM state carried through the episode and reset at the next one."""
    import teamgym
    from baselines.rl.sb3_env import TeamVecEnv

    config = {"max_cycles": 12}
    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", **config), n_envs=1)
    model = RecurrentPPO("MlpLstmPolicy", venv, n_steps=8, batch_size=8, seed=0, device="cpu")
    calls = []
    original = model.predict

    def spy(observation, state=None, episode_start=None, deterministic=False):
        calls.append((np.asarray(episode_start).copy(), state is None))
        return original(observation, state=state, episode_start=episode_start, deterministic=deterministic)

    monkeypatch.setattr(model, "predict", spy)
    data = collect_learner_data(teamgym.make("Navigation-v0", **config), model, "goto", 30, seed=2)
    assert data.starts is not None and data.starts[0] and data.starts.sum() >= 3  # each robot of the first episode starts a track
    first_steps = [starts for starts, _ in calls if starts.all()]
    assert len(first_steps) == data.episodes  # every episode starts from zero states, and only its first step
    assert all(not starts.any() for starts, _ in calls if not starts.all())
    venv.close()


def test_train_recurrent_with_behaviour_cloning_end_to_end(tmp_path):
    """``--algo recurrent-ppo --bc-expert``: the clone is fitted, DAgger runs with it, the sidecar records it."""
    out = tmp_path / "model.zip"
    code = train_main(
        [
            "--env", "Navigation-v0", "--algo", "recurrent-ppo", "--timesteps", "64", "--n-envs", "1",
            "--set", "max_cycles=20", "--hp", "n_steps=32", "--hp", "batch_size=32",
            "--bc-expert", "goto", "--bc-steps", "300", "--bc-epochs", "2", "--bc-dagger", "1",
            "--bc-dagger-steps", "120", "--bc-noise", "0", "--verbose", "0", "--out", str(out),
        ]
    )  # fmt: skip
    assert code in (0, None)
    bc = json.loads(out.with_suffix(".json").read_text())["bc"]
    assert bc["expert"] == "goto" and bc["sequence_length"] == 64 and len(bc["dagger_learner_success"]) == 1
    assert 0.0 <= bc["expert_success_rate"] <= 1.0 and np.isfinite(bc["action_loss"])


def test_the_masked_recurrent_clone_reads_the_masks_with_its_observations():
    """``maskable_recurrent_ppo``: each step's mask rides at the end of its observation, as in training; labels are admissible."""
    from baselines.rl.masked_recurrent import MaskedLstmPolicy

    space = gym.spaces.Discrete(3)

    class Masked(_Cue):
        def __init__(self) -> None:
            super().__init__(space)
            self.observation_space = gym.spaces.Box(-1.0, 1.0, (5,), np.float32)  # (cue, clock) + the mask of 3

    data = cue_data(episodes=16, length=100, discrete=True)
    data.actions = np.where(data.actions == 1, 2, 0)  # the cue's label is 2 or 0; 1 is never admissible
    data.masks = np.tile(np.array([True, False, True]), (len(data), 1))
    venv = DummyVecEnv([Masked])
    model = RecurrentPPO(MaskedLstmPolicy, venv, n_steps=8, batch_size=8, seed=0, device="cpu", policy_kwargs={"mask_width": 3})
    behaviour_clone(model, data, 30, batch_size=512, learning_rate=3e-3, fit_value=False)
    held_out = cue_data(episodes=4, length=100, discrete=True, seed=2)
    expected = np.where(held_out.actions == 1, 2, 0).reshape(-1)
    held_out.observations = np.concatenate([held_out.observations, np.tile([1.0, 0.0, 1.0], (len(held_out), 1))], axis=1)
    predicted = replay(model, held_out).reshape(-1)
    assert (predicted == expected).mean() > 0.95 and not (predicted == 1).any()
    data.masks[:, 2] = False  # now a label is an action its own mask forbids
    with pytest.raises(ValueError, match="its own action mask forbids"):
        behaviour_clone(model, data, 1)
