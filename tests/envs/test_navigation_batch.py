"""NavigationBatch: K copies stepped with arrays equal K single Navigation envs, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import teamgym
from teamgym.envs.base import EpisodeOverError
from teamgym.envs.config import ConfigError
from teamgym.envs.navigation.batch import NavigationBatch

CONFIGS = {
    "default": {"n_robots": 3, "max_cycles": 250},
    "wheels-unit-local-noise-delay": {
        "n_robots": 3,
        "action_type": "wheels",
        "normalize_actions": True,
        "local_features": True,
        "mate_goals": True,
        "virtual_forces": True,
        "sensor_noise": 0.01,
        "actuation_delay": 0.05,
        "max_cycles": 120,
    },
    "delay-past-a-step": {"n_robots": 3, "actuation_delay": 0.15, "max_cycles": 120},
    "heading": {"n_robots": 2, "action_type": "heading", "local_features": True, "max_cycles": 150},
    "one-robot-no-obstacles": {"n_robots": 1, "n_obstacles": 0, "max_cycles": 200},
    "crowded-no-walls": {"n_robots": 4, "n_obstacles": 4, "walls": False, "obstacle_motion": "straight", "max_cycles": 150},
}


def steer(batch: NavigationBatch, observations: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Drive towards the goals with some noise (so robots arrive at different steps), in the batch's action space."""
    layout, space = batch.layout, batch.action_space
    pose = observations[..., 0:3]
    goal = observations[..., layout.slices["goal_offset"]]
    error = np.arctan2(goal[..., 1], goal[..., 0]) - pose[..., 2]
    error = np.arctan2(np.sin(error), np.cos(error)) + rng.normal(0.0, 0.6, size=error.shape)
    if batch.config.action_type == "heading":
        return np.clip(np.round(2 + 2 * error / np.pi * 2), 0, space.n - 1).astype(np.int64)
    v = np.where(np.abs(error) < 0.6, 0.12, 0.02)
    omega = 3.0 * error
    if batch.config.action_type == "wheels":
        base = batch.copies[0].spec_robot.wheel_base
        command = np.stack([v - 0.5 * base * omega, v + 0.5 * base * omega], axis=-1)
    else:
        command = np.stack([v, omega], axis=-1)
    if batch.config.normalize_actions:
        inner = batch.copies[0].action_type.inner.space()
        command = 2 * (command - inner.low) / (inner.high - inner.low) - 1
    return np.clip(command, space.low, space.high).astype(np.float32)


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_batch_steps_as_single_envs_do(name):
    config, k = CONFIGS[name], 3
    batch = NavigationBatch(k, **config)
    observations = batch.reset(seed=40)
    envs = [teamgym.make("Navigation-v0", **config) for _ in range(k)]
    single = [env.reset(seed=40 + e)[0] for e, env in enumerate(envs)]
    for e, env in enumerate(envs):
        for i, agent in enumerate(env.possible_agents):
            assert np.array_equal(single[e][agent], observations[e, i])
    rng = np.random.default_rng(0)
    finished_early = arrivals = 0
    while batch.active.any():
        actions = steer(batch, observations, rng)
        observations, rewards, terminated, truncated = batch.step(actions)
        for e, env in enumerate(envs):
            if not env.agents:
                continue
            acting = {a: actions[e, i] for i, a in enumerate(env.possible_agents) if a in env.agents}
            obs, rew, term, trunc, infos = env.step(acting)
            batch_infos = batch.infos(e)
            for i, agent in enumerate(env.possible_agents):
                if agent not in acting:
                    assert rewards[e, i] == 0 and not terminated[e, i] and not truncated[e, i]
                    continue
                assert np.array_equal(obs[agent], observations[e, i]), (e, agent)
                assert rew[agent] == rewards[e, i]
                assert term[agent] == terminated[e, i] and trunc[agent] == truncated[e, i]
                assert infos[agent].keys() == batch_infos[agent].keys()
                for key, value in infos[agent].items():
                    assert value == batch_infos[agent][key], (key, value, batch_infos[agent][key])
                finished_early += bool(term[agent] and env.agents)
                arrivals += bool(term[agent])
            assert [a for i, a in enumerate(env.possible_agents) if batch.active[e, i]] == env.agents
    assert batch.episode_over().all()
    if name != "heading":  # the steering brings robots home one by one: the masks are exercised
        assert arrivals > 0 and (finished_early > 0 or config["n_robots"] == 1)


def test_reset_copy_and_growth_keep_other_copies():
    batch = NavigationBatch(2, n_robots=2, max_cycles=50)
    batch.reset(seed=1)
    rng = np.random.default_rng(3)
    space = batch.action_space
    for _ in range(5):
        batch.step(rng.uniform(space.low, space.high, size=(2, 2, 2)).astype(np.float32))
    before = batch.copies[0].state().copy()
    k = batch.add_copy()
    assert k == 2 and batch.n_copies == 3 and not batch.active[2].any()
    with pytest.raises(EpisodeOverError, match="never reset"):
        batch.step(np.zeros((3, 2, 2), np.float32))
    rows, infos = batch.reset_copy(2, seed=9)
    fresh = teamgym.make("Navigation-v0", n_robots=2, max_cycles=50)
    expected, _ = fresh.reset(seed=9)
    assert np.array_equal(rows[1], expected["robot_1"]) and set(infos) == {"robot_0", "robot_1"}
    assert np.array_equal(batch.copies[0].state(), before)
    batch.truncate(1)
    assert batch.n_copies == 1 and batch.copies[0]._arrays.n_copies == 1 and batch.active.shape == (1, 2)
    assert np.array_equal(batch.copies[0].state(), before)


def test_rejected_actions_change_nothing():
    batch = NavigationBatch(2, n_robots=2, max_cycles=50)
    first = batch.reset(seed=5)
    bad = np.zeros((2, 2, 2), dtype=np.float32)
    bad[1, 0, 1] = np.nan
    with pytest.raises(ValueError, match="robot_0.*NaN"):
        batch.step(bad)
    with pytest.raises(ValueError, match="outside the space bounds"):
        batch.step(np.full((2, 2, 2), 50.0, np.float32))
    with pytest.raises(ValueError, match="shape"):
        batch.step(np.zeros((2, 3, 2), np.float32))
    assert all(env.cycles == 0 for env in batch.copies)
    again = NavigationBatch(2, n_robots=2, max_cycles=50)
    assert np.array_equal(again.reset(seed=5), first)
    good = np.zeros((2, 2, 2), np.float32)
    assert np.array_equal(batch.step(good)[0], again.step(good)[0])


def test_actions_of_finished_robots_are_ignored():
    batch = NavigationBatch(1, n_robots=2, max_cycles=400)
    observations = batch.reset(seed=0)
    rng = np.random.default_rng(1)
    while batch.active.all():
        observations, *_ = batch.step(steer(batch, observations, rng))
    assert batch.active.any(), "both robots finished in the same step; pick another seed"
    actions = steer(batch, observations, rng)
    actions[~batch.active] = np.nan  # the finished robot's row is not checked
    batch.step(actions)
    while batch.active.any():
        batch.step(np.zeros((1, 2, 2), np.float32))
    with pytest.raises(EpisodeOverError):
        batch.step(np.zeros((1, 2, 2), np.float32))


@pytest.mark.parametrize(
    "kwargs, error",
    [
        ({"n_copies": 0}, ValueError),
        ({"n_copies": 2, "fixed_agents": True}, ConfigError),
        ({"n_copies": 1, "n_robots": 0}, ConfigError),
    ],
)
def test_invalid_batches_are_refused(kwargs, error):
    with pytest.raises(error):
        NavigationBatch(**kwargs)


def test_free_rings_read_what_the_rays_read():
    """A robot the batch calls free (nothing within range) reads sensor_range on every ray when cast."""
    batch = NavigationBatch(4, n_robots=4, n_obstacles=4, max_cycles=400)
    observations = batch.reset(seed=11)
    rng = np.random.default_rng(2)
    checked = {True: 0, False: 0}
    for _ in range(150):
        observations, *_ = batch.step(steer(batch, observations, rng))
        free = batch.copies[0]._arrays.sensing_free(slice(None))
        for e, env in enumerate(batch.copies):
            for i, robot in enumerate(env.robot_list):
                reading = env.ring.read(robot, env.world.space, pose=tuple(env.world.robot_states[i, :3]))
                if free[e, i]:
                    assert np.all(reading == env.config.sensor_range)
                checked[bool(free[e, i])] += 1
    assert checked[True] > 0 and checked[False] > 0


def test_the_old_name_is_the_batch_of_navigation_copies():
    assert isinstance(teamgym.make("Navigation-v0").make_batch(2), NavigationBatch.__mro__[1])
    batch = teamgym.make_batch("Navigation-v0", 2, n_robots=4)
    old = NavigationBatch(2, n_robots=4)
    assert np.array_equal(batch.reset(seed=0), old.reset(seed=0)) and batch.config == old.config
    with pytest.raises(ValueError, match="n_copies"):
        teamgym.make_batch("Navigation-v0", 0)


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_batch_and_its_copies_pickle_mid_episode(how):
    import copy
    import pickle

    config = {"n_robots": 2, "action_type": "heading", "max_cycles": 200}
    batch = NavigationBatch(3, **config)
    observations = batch.reset(seed=21)
    rng = np.random.default_rng(5)
    for _ in range(40):
        observations, *_ = batch.step(steer(batch, observations, rng))
    clone = pickle.loads(pickle.dumps(batch)) if how == "pickle" else copy.deepcopy(batch)
    single = pickle.loads(pickle.dumps(batch.copies[1]))  # a copy alone continues as its copy in the batch
    assert np.array_equal(clone.active, batch.active)
    for _ in range(60):
        if not batch.active.any():
            break
        actions = steer(batch, observations, rng)
        observations, rewards, terminated, truncated = batch.step(actions)
        again, again_rewards, *_ = clone.step(actions)
        assert np.array_equal(observations, again) and np.array_equal(rewards, again_rewards)
        if single.agents:
            alone, alone_rewards, *_ = single.step(
                {a: actions[1, i] for i, a in enumerate(single.possible_agents) if a in single.agents}
            )
            for i, agent in enumerate(single.possible_agents):
                if agent in alone:
                    assert np.array_equal(alone[agent], observations[1, i]) and alone_rewards[agent] == rewards[1, i]
