"""Tests of the Stable-Baselines3 adapter (``TeamVecEnv``), ``SB3Policy`` and training."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces

pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.monitor import Monitor  # noqa: E402
from stable_baselines3.common.vec_env import VecEnv  # noqa: E402

import teamgym  # noqa: E402
from baselines.evaluate import evaluate  # noqa: E402
from baselines.rl.sb3_env import TeamVecEnv  # noqa: E402
from baselines.rl.sb3_policy import SB3Policy, detect_algorithm  # noqa: E402

CONFIG = {"max_cycles": 12, "n_robots": 2, "n_obstacles": 1}


@pytest.fixture(autouse=True)
def _one_torch_thread(single_thread_torch):
    """Every test here runs torch on one thread (the shared fixture in conftest.py)."""


def make_env():
    return teamgym.make("Navigation-v0", **CONFIG)


class StaggeredEnv:
    """A minimal parallel env: agent ``i`` terminates after ``i + 1`` steps, the rest truncate at ``horizon``.

    The episode succeeds when every agent has terminated (none truncated).
    """

    metadata: dict[str, Any] = {"render_modes": []}
    render_mode = None

    def __init__(self, n: int = 3, horizon: int = 4) -> None:
        self.possible_agents = [f"a{i}" for i in range(n)]
        self.agents: list[str] = []
        self.horizon = horizon
        self.t = 0
        self.finish = {a: i + 1 for i, a in enumerate(self.possible_agents)}
        self.resets = 0

    def observation_space(self, agent):
        return spaces.Box(-np.inf, np.inf, shape=(2,), dtype=np.float32)

    def action_space(self, agent):
        return spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)

    def _obs(self, agent):
        return np.array([1.0 + self.possible_agents.index(agent), 1.0 + self.t], dtype=np.float32)

    def reset(self, seed=None, options=None):
        self.agents = list(self.possible_agents)
        self.t = 0
        self.resets += 1
        return {a: self._obs(a) for a in self.agents}, {a: {} for a in self.agents}

    def step(self, actions):
        assert set(actions) == set(self.agents)
        for a in actions:
            assert -1.0 <= float(actions[a][0]) <= 1.0
        self.t += 1
        obs = {a: self._obs(a) for a in self.agents}
        rewards = {a: 1.0 for a in self.agents}
        terms = {a: self.t >= self.finish[a] for a in self.agents}
        truncs = {a: self.t >= self.horizon and not terms[a] for a in self.agents}
        success = self.t >= max(self.finish.values())
        infos = {a: {"success": success} for a in self.agents}
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        return obs, rewards, terms, truncs, infos

    def close(self):
        pass


def test_team_vec_env_contract():
    venv = TeamVecEnv(make_env, n_envs=2)
    assert isinstance(venv, VecEnv)
    assert venv.num_envs == 4
    assert venv.observation_space == make_env().observation_space("robot_0")
    venv.seed(7)
    obs = venv.reset()
    assert obs.shape == (4, *venv.observation_space.shape) and obs.dtype == np.float32
    assert all(venv.observation_space.contains(o) for o in obs)
    assert not np.array_equal(obs[0], obs[2])  # env copies get different seeds
    episodes = 0
    for _ in range(2 * CONFIG["max_cycles"] + 2):
        actions = np.stack([venv.action_space.sample() for _ in range(venv.num_envs)])
        obs, rewards, dones, infos = venv.step(actions)
        assert obs.shape == (4, *venv.observation_space.shape) and obs.dtype == np.float32
        assert rewards.shape == (4,) and rewards.dtype == np.float32
        assert dones.shape == (4,) and dones.dtype == bool
        assert isinstance(infos, list) and len(infos) == 4
        for k in np.nonzero(dones)[0]:
            terminal = infos[k]["terminal_observation"]
            assert terminal.shape == venv.observation_space.shape
            assert isinstance(infos[k]["TimeLimit.truncated"], bool)
            if "episode" in infos[k]:
                episodes += 1
    assert episodes >= 4
    # Reseeding reproduces the first observations.
    again = TeamVecEnv(make_env, n_envs=2)
    again.seed(7)
    venv.seed(7)
    assert np.array_equal(again.reset(), venv.reset())
    assert venv.get_attr("render_mode") == [None] * 4
    assert venv.env_is_wrapped(object) == [False] * 4
    assert venv.env_is_wrapped(Monitor) == [True] * 4  # slots write Monitor's info["episode"]
    venv.close()


def test_team_vec_env_one_copy_waits_for_the_whole_team():
    """With one copy, a slot whose robot finished waits (padding) until the team is done."""
    venv = TeamVecEnv(lambda: StaggeredEnv(n=3, horizon=4), n_envs=1)
    venv.reset()
    actions = np.full((3, 1), 5.0, dtype=np.float32)  # out of bounds: must be clipped, not rejected
    # step 1: a0 terminates (done once, real reward, terminal obs)
    obs, rew, done, info = venv.step(actions)
    assert done.tolist() == [True, False, False]
    assert rew.tolist() == [1.0, 1.0, 1.0]
    assert np.array_equal(info[0]["terminal_observation"], [1.0, 2.0])
    assert info[0]["TimeLimit.truncated"] is False
    assert "is_success" not in info[0]  # the team's success is known when the team's episode ends
    assert info[0]["episode"]["r"] == 1.0 and info[0]["episode"]["l"] == 1
    assert np.all(obs[0] == 0) and np.array_equal(obs[1], [2.0, 2.0])
    # step 2: slot 0 waits (padding), a1 terminates
    obs, rew, done, info = venv.step(actions)
    assert done.tolist() == [False, True, False]
    assert rew.tolist() == [0.0, 1.0, 1.0]
    assert info[0] == {"padding": True}
    assert np.all(obs[0] == 0) and np.all(obs[1] == 0)
    # step 3: a2 terminates, three slots are free -> the idle copy restarts; waits close with done
    obs, rew, done, info = venv.step(actions)
    assert venv.envs[0].resets == 2 and len(venv.envs) == 1
    assert done.all()
    assert info[2]["episode"]["l"] == 3 and info[2]["is_success"] is True
    for k in (0, 1):  # waiting slots: no success (it went with slot 2's done) and no episode
        assert info[k]["padding"] and "is_success" not in info[k] and "episode" not in info[k]
    assert np.all(info[0]["terminal_observation"] == 0) and info[0]["TimeLimit.truncated"] is False
    assert rew.tolist() == [0.0, 0.0, 1.0]
    assert np.array_equal(obs, [[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]])  # first observations of the new episode
    # padding: slot 0 during steps 2 and 3, slot 1 during step 3 (of 9 slot-steps)
    assert venv.slot_steps == 9 and venv.padding_steps == 3


def test_team_vec_env_refills_free_slots_from_another_copy():
    venv = TeamVecEnv(lambda: StaggeredEnv(n=3, horizon=10), n_envs=2)
    venv.reset()
    actions = np.zeros((6, 1), dtype=np.float32)
    # step 1: a0 of both copies finishes -> slots 0 and 3 free, not enough for a team of 3
    _, _, done, info = venv.step(actions)
    assert done.tolist() == [True, False, False, True, False, False]
    # step 2: a1 of both finishes -> free: 0, 3 (waited a step), 1, 4 -> a third copy takes 0, 3, 1
    obs, _, done, info = venv.step(actions)
    assert len(venv.envs) == 3
    assert done.tolist() == [True, True, False, True, True, False]
    assert info[0] == {"padding": True, "terminal_observation": info[0]["terminal_observation"], "TimeLimit.truncated": False}
    assert info[1]["episode"]["l"] == 2  # its own robot's done; the new robot's first obs is returned
    assert np.array_equal(obs[[0, 3, 1]], [[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]])
    assert np.all(obs[4] == 0)  # slot 4 waits
    assert venv.padding_steps == 2 and venv.slot_steps == 12
    # step 3: a2 of copies 0 and 1 finish, and a0 of the new copy (slot 0): slots 4, 2, 5 restart copy 0
    obs, _, done, info = venv.step(actions)
    assert done.tolist() == [True, False, True, False, True, True]
    assert info[2]["is_success"] is True and info[5]["is_success"] is True
    assert info[4]["padding"] is True and "episode" not in info[4]
    assert np.array_equal(obs[[4, 2, 5]], [[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]])
    assert len(venv.envs) == 3 and venv.envs[0].resets == 2 and venv.envs[1].resets == 1
    # step 4: a0 of copy 0 (slot 4) and a1 of copy 2 (slot 3) finish: slots 0, 4, 3 restart copy 1
    obs, _, done, info = venv.step(actions)
    assert done.tolist() == [True, False, False, True, True, False]
    assert venv.get_attr("resets") == [2, 1, 2, 2, 2, 2]  # slot 1 still serves copy 2, the rest copies 0 and 1
    assert venv.padding_steps == 2 + 1 + 1  # slot 4 in step 3, slot 0 in step 4


def test_padding_share_falls_with_more_copies():
    """A robot finishes at steps 1, 2, 3 of each team episode; with one copy a third of the
    slot-steps are padding (the old adapter's share at any ``n_envs``), with more copies far less."""

    def share(n_envs: int) -> float:
        venv = TeamVecEnv(lambda: StaggeredEnv(n=3, horizon=10), n_envs=n_envs)
        venv.reset()
        for _ in range(60):
            venv.step(np.zeros((venv.num_envs, 1), dtype=np.float32))
        return venv.padding_share

    assert share(1) == pytest.approx(1 / 3, abs=0.02)
    assert share(8) < 0.05


def test_evaluate_policy_counts_true_robot_returns():
    """SB3's evaluate_policy sees Monitor-style episodes: each robot's return (1 per step), no padding."""
    from stable_baselines3.common.evaluation import evaluate_policy

    class Zero:
        def predict(self, observation, state=None, episode_start=None, deterministic=False):
            return np.zeros((len(observation), 1), dtype=np.float32), state

    venv = TeamVecEnv(lambda: StaggeredEnv(n=3, horizon=10), n_envs=1)
    returns, lengths = evaluate_policy(Zero(), venv, n_eval_episodes=30, return_episode_rewards=True, warn=True)
    assert sorted(set(returns)) == [1.0, 2.0, 3.0] and returns == lengths
    assert np.mean(returns) == pytest.approx(2.0)


def test_refilled_runs_are_bit_identical():
    def run() -> list[np.ndarray]:
        venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", **CONFIG), n_envs=2)
        venv.seed(3)
        out = [venv.reset()]
        rng = np.random.default_rng(0)
        for _ in range(40):
            actions = rng.uniform(-1, 1, size=(venv.num_envs, *venv.action_space.shape)).astype(np.float32)
            obs, rewards, dones, _ = venv.step(actions)
            out += [obs, rewards, dones]
        return out

    first, second = run(), run()
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))


def test_action_masks_have_maskable_ppo_shape():
    pytest.importorskip("sb3_contrib")
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.utils import get_action_masks

    config = {"n_robots": 2, "action_type": "operator", "max_cycles": 30}
    venv = TeamVecEnv(lambda: teamgym.make("Exploration-v0", **config), n_envs=2)
    venv.reset()
    masks = get_action_masks(venv)
    assert masks.shape == (venv.num_envs, venv.action_space.n) and masks.dtype == bool
    first = venv.envs[0]
    assert np.array_equal(masks[1], first.action_mask("robot_1").astype(bool))
    model = MaskablePPO("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=1, seed=0)
    model.learn(64)  # a masked action would raise inside the env
    assert model.num_timesteps >= 64


def test_is_success_is_the_teams_success_on_any_env():
    # Exploration-v0, one robot starting in its only goal sector: the episode succeeds in one step.
    config = {"n_robots": 1, "goal_sectors": ("S4",), "start_sectors": ("S4",), "max_cycles": 5}
    venv = TeamVecEnv(lambda: teamgym.make("Exploration-v0", **config), n_envs=1)
    venv.reset()
    _, _, done, info = venv.step(np.zeros((1, *venv.action_space.shape), dtype=np.float32))
    assert done.tolist() == [True]
    assert "arrived" not in info[0] and info[0]["is_success"] is True
    # Two robots whose goal sector is elsewhere: truncated without success.
    config = {"n_robots": 2, "goal_sectors": ("S1",), "start_sectors": ("S4", "S9"), "max_cycles": 2}
    venv = TeamVecEnv(lambda: teamgym.make("Exploration-v0", **config), n_envs=1)
    venv.reset()
    for _ in range(2):
        _, _, done, info = venv.step(np.zeros((2, *venv.action_space.shape), dtype=np.float32))
    assert done.all() and [i.get("is_success") for i in info] == [False, None]  # once per team episode


def test_is_success_reads_only_the_episode_contract(monkeypatch):
    from teamgym.envs.box_pushing import BoxPushing

    monkeypatch.setattr(BoxPushing, "episode_success", lambda self: True)
    venv = TeamVecEnv(lambda: teamgym.make("BoxPushing-v0", situation="S2", max_cycles=3), n_envs=1)
    venv.reset()
    for _ in range(3):
        _, _, done, info = venv.step(np.zeros(venv.num_envs, dtype=np.int64))
    assert done.all() and info[0]["is_success"] is True
    assert all("is_success" not in i for i in info[1:])  # once per team episode


#: A small, easy task for the learning test: two robots, no obstacles, a 1 m arena, goals
#: 0.3 m or more away, 4 s episodes, wheel-speed actions.
LEARN_CONFIG = {
    "n_robots": 2,
    "n_obstacles": 0,
    "arena_size": 1.0,
    "min_goal_distance": 0.3,
    "max_cycles": 40,
    "action_type": "wheels",
}
#: Evaluation seeds 1000..1009, never used to reset a training env (those start at seeds 0 and 2).
HELD_OUT_SEED, HELD_OUT_EPISODES = 1000, 10


def held_out_scores(path):
    """Mean team return and mean final distance to goal (m) of a saved model on the held-out seeds."""
    results = evaluate("Navigation-v0", f"sb3:{path}", episodes=HELD_OUT_EPISODES, seed=HELD_OUT_SEED, config=LEARN_CONFIG)
    assert len(results) == HELD_OUT_EPISODES
    assert all(set(r.metrics) == {"robot_0", "robot_1"} and 1 <= r.length <= LEARN_CONFIG["max_cycles"] for r in results)
    distance = np.mean([m["distance_to_goal"] for r in results for m in r.metrics.values()])
    return float(np.mean([r.mean_return for r in results])), float(distance)


def test_ppo_learns_saves_and_evaluates(tmp_path):
    """PPO improves on its own initial policy on held-out seeds; the saved model loads and evaluates.

    About 8k agent transitions (a few seconds on one thread). Measured with these seeds:
    mean return -0.39 -> 0.88, final distance to goal 0.53 m -> 0.41 m; with
    ``learning_rate=0`` both stay at the untrained values and the test fails.
    """
    venv = TeamVecEnv(lambda: teamgym.make("Navigation-v0", **LEARN_CONFIG), n_envs=2)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=128,
        batch_size=128,
        n_epochs=5,
        learning_rate=3e-3,
        gamma=0.9,
        clip_range=0.3,
        policy_kwargs={"log_std_init": -1.5},
        seed=0,
        device="cpu",
    )
    untrained = tmp_path / "untrained.zip"
    model.save(str(untrained))
    model.learn(total_timesteps=8192)
    assert model.num_timesteps >= 8192
    path = tmp_path / "ppo_model.zip"
    model.save(str(path))
    venv.close()
    assert detect_algorithm(path) == "ppo"

    before_return, before_distance = held_out_scores(untrained)
    after_return, after_distance = held_out_scores(path)
    assert after_return > before_return + 0.5, (before_return, after_return)
    assert after_distance < before_distance - 0.05, (before_distance, after_distance)

    env = teamgym.make("Navigation-v0", **LEARN_CONFIG)
    policy = SB3Policy.load(path, env)
    calls = []
    predict = policy.model.predict

    def counting_predict(batch, **kwargs):
        calls.append(batch.shape)
        return predict(batch, **kwargs)

    policy.model.predict = counting_predict
    observations, _ = env.reset(seed=0)
    actions = policy.act(observations)
    assert calls == [(2, env.observation_space("robot_0").shape[0])]  # one batched call for both robots
    for agent, action in actions.items():
        assert env.action_space(agent).contains(action)
    repeat = policy.act(observations)  # deterministic
    assert all(np.array_equal(actions[a], repeat[a]) for a in actions)


def test_sb3_policy_rejects_mismatched_env(tmp_path):
    venv = TeamVecEnv(make_env, n_envs=1)
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=16, device="cpu")
    model.save(str(tmp_path / "m.zip"))
    other = teamgym.make("Navigation-v0", n_robots=4)
    with pytest.raises(ValueError, match="observations of shape"):
        SB3Policy.load(tmp_path / "m", other)


def test_train_cli_ppo_and_dqn(tmp_path):
    from baselines.train import main as train_main

    out = tmp_path / "ppo"
    assert (
        train_main(
            [
                "--timesteps",
                "64",
                "--set",
                "n_robots=2",
                "--max-cycles",
                "10",
                "--n-envs",
                "1",
                "--out",
                str(out),
                "--verbose",
                "0",
            ]
        )
        == 0
    )
    meta = json.loads((tmp_path / "ppo.json").read_text())
    assert meta["algo"] == "ppo" and meta["config"]["n_robots"] == 2 and meta["agents_per_env"] == 2
    policy = SB3Policy.load(tmp_path / "ppo.zip", teamgym.make("Navigation-v0", n_robots=2))
    assert policy.algo == "ppo"

    dqn = tmp_path / "dqn.zip"
    args = ["--algo", "dqn", "--timesteps", "64", "--set", "action_type=heading", "--max-cycles", "10", "--hp", "buffer_size=500"]
    assert train_main([*args, "--hp", "learning_starts=16", "--out", str(dqn), "--verbose", "0"]) == 0
    assert detect_algorithm(dqn) == "dqn"
    results = evaluate("Navigation-v0", f"sb3:{dqn}", episodes=1, seed=0, config={"action_type": "heading", "max_cycles": 10})
    assert results[0].length == 10 or results[0].success


def test_train_cli_bad_config_exits_2(tmp_path, capsys):
    from baselines.train import main as train_main

    assert train_main(["--set", "bogus=1", "--out", str(tmp_path / "m.zip")]) == 2
    assert "bogus" in capsys.readouterr().err
    assert not (tmp_path / "m.zip").exists()


def test_worker_processes_match_the_seeding_of_one_process():
    from baselines.rl.subproc import SubprocTeamVecEnv, split_copies

    assert split_copies(5, 2) == [3, 2]
    with pytest.raises(ValueError, match="n_workers"):
        split_copies(1, 2)
    one = TeamVecEnv(make_env, n_envs=3)
    workers = SubprocTeamVecEnv(make_env, n_envs=3, n_workers=2)
    try:
        assert workers.num_envs == one.num_envs == 6 and workers.observation_space == one.observation_space
        one.seed(5)
        workers.seed(5)
        assert np.array_equal(one.reset(), workers.reset())  # copy e reset with 5 + e·A in both
        rng = np.random.default_rng(0)
        steps = 0
        while steps < 3 * CONFIG["max_cycles"]:
            actions = rng.uniform(-1, 1, size=(6, *one.action_space.shape)).astype(np.float32)
            a, b = one.step(actions), workers.step(actions)
            steps += 1
            if not any(b[2]):  # identical until the first refill, which draws from each worker's own pool
                assert all(np.array_equal(x, y) for x, y in zip(a[:3], b[:3]))
        assert workers.get_attr("possible_agents", [0])[0] == ["robot_0", "robot_1"]
        assert 0.0 <= workers.padding_share < 1.0
        assert workers.env_is_wrapped(Monitor) == [True] * 6
    finally:
        workers.close()
        one.close()


def test_worker_runs_are_bit_identical():
    from baselines.rl.subproc import SubprocTeamVecEnv

    def run() -> tuple[list[np.ndarray], list[int]]:
        venv = SubprocTeamVecEnv(make_env, n_envs=3, n_workers=2)
        venv.seed(11)
        out = [venv.reset()]
        rng = np.random.default_rng(1)
        for _ in range(3 * CONFIG["max_cycles"]):
            obs, rewards, dones, _ = venv.step(rng.uniform(-1, 1, size=(6, 2)).astype(np.float32))
            out += [obs, rewards, dones]
        venv.close()
        return out

    first, second = run(), run()
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))


class SeedRecordingEnv(StaggeredEnv):
    def reset(self, seed=None, options=None):
        self.seeds = [*getattr(self, "seeds", []), seed]
        return super().reset(seed, options)


def test_copies_added_to_the_pool_get_their_own_seeds():
    """A worker's pool copies are numbered after every worker's first copies, interleaved by worker."""
    venv = TeamVecEnv(lambda: SeedRecordingEnv(n=3, horizon=10), n_envs=2)
    venv.slot_offset, venv.extra_copy_numbers = 6, (5, 2)  # as worker 1 of 2 serving copies 2-3 of 5
    venv.seed(100 + 6)
    venv.reset()
    for _ in range(4):
        venv.step(np.zeros((6, 1), dtype=np.float32))
    assert [env.seeds[0] for env in venv.envs] == [106, 109, 115]  # copies 2, 3, then number 5 (seed 100 + 5·3)
    assert venv.envs[0].seeds[1:] == [None]  # an idle copy restarts on its own stream
