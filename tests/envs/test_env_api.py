"""PettingZoo API conformance of every registered env, determinism, copying and rendering."""

import copy
import importlib
import pickle
import typing

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, render_test, seed_test

import teamgym


def env_cases():
    """(env id, config) pairs: every registered id, once per ``action_type`` it offers and per
    observation format, plus one case per id with a learned message (``comm_dim``) through the channel."""
    cases = []
    for env_id in teamgym.envs():
        config_class = teamgym.env_class(env_id).config_class
        hint = typing.get_type_hints(config_class).get("action_type")
        kinds = typing.get_args(hint) if typing.get_origin(hint) is typing.Literal else (None,)
        for kind in kinds:
            for obs_format in ("flat", "dict"):
                config = {"max_cycles": 25, "obs_format": obs_format}
                if kind is not None:
                    config["action_type"] = kind
                suffix = "" if obs_format == "flat" else "-dict"
                cases.append(pytest.param(env_id, config, id=f"{env_id}-{kind or 'default'}{suffix}"))
        comm = {"max_cycles": 25, "obs_format": "dict", "comm_dim": 2, "comm_throughput": 0.5, "comm_latency": 1}
        cases.append(pytest.param(env_id, comm, id=f"{env_id}-comm"))
        for kind in kinds:  # unit-scaled actions on every continuous action type
            config = {"max_cycles": 25, "normalize_actions": True, **({"action_type": kind} if kind else {})}
            try:
                teamgym.make(env_id, **config).close()
            except teamgym.ConfigError:
                continue  # a discrete action type
            cases.append(pytest.param(env_id, config, id=f"{env_id}-{kind or 'default'}-unit"))
    cases.append(pytest.param("Navigation-v0", {"max_cycles": 25, "local_features": True}, id="Navigation-v0-local"))
    cases.append(
        pytest.param(
            "Navigation-v0", {"max_cycles": 25, "local_features": True, "mate_goals": True}, id="Navigation-v0-mate-goals"
        )
    )
    return cases


CASES = env_cases()


def module_of(env_id):
    return importlib.import_module(teamgym.env_class(env_id).__module__)


def test_navigation_has_all_action_types():
    ids = {p.id for p in CASES}
    assert {"Navigation-v0-velocity", "Navigation-v0-wheels", "Navigation-v0-heading"} <= ids


def test_box_pushing_has_all_action_types():
    ids = {p.id for p in CASES}
    assert {"BoxPushing-v0-primitives", "BoxPushing-v0-wheels"} <= ids


def test_exploration_has_all_action_types():
    ids = {p.id for p in CASES}
    assert {"Exploration-v0-velocity", "Exploration-v0-operator"} <= ids


@pytest.fixture
def random_policy(random_policy):
    """The shared random policy; envs with action masks (``env.action_masks()``) draw admissible actions."""

    def act(env, rng):
        actions = random_policy(env, rng)
        for agent, mask in getattr(env, "action_masks", dict)().items():
            choice = int(rng.choice(np.flatnonzero(mask)))
            if isinstance(actions[agent], dict):  # motion + message: the mask is the motion's
                actions[agent]["motion"] = choice
            else:
                actions[agent] = choice
        return actions

    return act


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_parallel_api(env_id, config):
    parallel_api_test(teamgym.make(env_id, **config), num_cycles=40)


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_parallel_seed(env_id, config):
    parallel_seed_test(lambda: teamgym.make(env_id, **config), num_cycles=20)


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_aec_api(env_id, config):
    api_test(teamgym.make_aec(env_id, **config), num_cycles=20)


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_aec_api_through_module_env(env_id, config):
    api_test(module_of(env_id).env(**config), num_cycles=10)


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_aec_seed(env_id, config):
    seed_test(lambda: teamgym.make_aec(env_id, **config), num_cycles=20)
    seed_test(lambda: module_of(env_id).env(**config), num_cycles=5)


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_render_rgb_array(env_id, config):
    def env_fn(render_mode=None):
        env = teamgym.make_aec(env_id, render_mode=render_mode, **config)
        env.metadata = {**env.metadata, "render_modes": ["rgb_array"]}  # "human" is tested separately
        return env

    render_test(env_fn)


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_state_matches_state_space(env_id, config, random_policy):
    env = teamgym.make(env_id, **config)
    with pytest.raises(RuntimeError, match="reset"):
        env.state()
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(3):
        state = env.state()
        assert state.shape == env.state_space.shape
        assert state.dtype == env.state_space.dtype
        assert env.state_space.contains(state)
        if not env.agents:  # macro-action envs may use up max_cycles in a few steps
            break
        env.step(random_policy(env, rng))


@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_spaces_are_stable_and_observations_fit(env_id, config, random_policy):
    env = teamgym.make(env_id, **config)
    observations, infos = env.reset(seed=1)
    assert set(observations) == set(infos) == set(env.agents) == set(env.possible_agents)
    rng = np.random.default_rng(1)
    for _ in range(5):
        for agent, obs in observations.items():
            assert env.observation_space(agent) is env.observation_space(agent)
            assert env.observation_space(agent).contains(obs), (agent, obs)
        if not env.agents:
            break
        observations, rewards, terminations, truncations, infos = env.step(random_policy(env, rng))
        assert all(isinstance(r, float) and np.isfinite(r) for r in rewards.values())
        assert all(isinstance(t, bool) for t in [*terminations.values(), *truncations.values()])


# -- determinism --------------------------------------------------------------------------


def rollout(env, seed, steps=100):
    """Observations, rewards and infos of a seeded random-policy episode."""
    observations, infos = env.reset(seed=seed)
    rng = np.random.default_rng(seed + 1000)
    record = [(observations, infos)]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {}
        for agent in env.agents:
            space = env.action_space(agent)
            space.seed(int(rng.integers(2**31)))
            actions[agent] = space.sample()
        observations, rewards, terminations, truncations, infos = env.step(actions)
        record.append((observations, rewards, infos, terminations, truncations))
    return record


def assert_same_record(a, b):
    assert len(a) == len(b)
    for step_a, step_b in zip(a, b):
        for part_a, part_b in zip(step_a, step_b):
            assert part_a.keys() == part_b.keys()
            for agent in part_a:
                if isinstance(part_a[agent], np.ndarray):
                    np.testing.assert_array_equal(part_a[agent], part_b[agent])
                else:
                    assert part_a[agent] == part_b[agent]


@pytest.mark.parametrize("action_type", ["velocity", "heading"])
def test_same_seed_same_trajectory(action_type):
    kwargs = dict(max_cycles=100, action_type=action_type, n_robots=4, n_obstacles=3, sensor_noise=0.005)
    first = rollout(teamgym.make("Navigation-v0", **kwargs), seed=11)
    env = teamgym.make("Navigation-v0", **kwargs)
    rollout(env, seed=3)  # a different episode in between must not matter
    second = rollout(env, seed=11)
    assert len(first) == 101
    assert_same_record(first, second)


def test_different_seeds_different_starts():
    env = teamgym.make("Navigation-v0")
    starts = []
    for seed in range(4):
        observations, _ = env.reset(seed=seed)
        starts.append(np.concatenate([env.state(), observations["robot_0"]]))
    for i in range(len(starts)):
        for j in range(i):
            assert not np.allclose(starts[i], starts[j])


# -- copying mid-episode ----------------------------------------------------------------


def stepping_record(env, steps, seed):
    rng = np.random.default_rng(seed)
    record = []
    for _ in range(steps):
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) * env.action_space(a).high for a in env.agents}
        record.append(env.step(actions))
    return record


def assert_same_steps(a, b):
    for (obs_a, rew_a, term_a, trunc_a, info_a), (obs_b, rew_b, term_b, trunc_b, info_b) in zip(a, b):
        assert obs_a.keys() == obs_b.keys()
        for agent in obs_a:
            np.testing.assert_array_equal(obs_a[agent], obs_b[agent])
        assert (rew_a, term_a, trunc_a, info_a) == (rew_b, term_b, trunc_b, info_b)


def live_contacts(env):
    arbiters = []
    for body in env.world.space.bodies:
        body.each_arbiter(arbiters.append)
    return len(arbiters)


def env_mid_episode(in_contact):
    """A Navigation episode some steps in: either with no touching bodies at all, or right
    after robots have hit the arena walls (shapes overlapping while the solver pushes them apart)."""
    if in_contact:
        env = teamgym.make("Navigation-v0", n_robots=5, n_obstacles=2, max_cycles=300)
        env.reset(seed=8)
        for _ in range(100):
            env.step({a: np.array([0.4, 0.0], dtype=np.float32) for a in env.agents})  # into the walls
            if env.world.contacts:
                break
    else:
        env = teamgym.make("Navigation-v0", n_robots=5, n_obstacles=2, obstacle_speed=0.0, max_cycles=300)
        env.reset(seed=8)
        for _ in range(30):
            env.step({a: np.array([0.0, 0.5], dtype=np.float32) for a in env.agents})  # turn on the spot
    assert (live_contacts(env) > 0) == in_contact
    return env


COPIERS = {"deepcopy": copy.deepcopy, "pickle": lambda env: pickle.loads(pickle.dumps(env)), "copy": lambda env: env.copy()}


def assert_same_value(a, b, where):
    """Exact equality of nested step outputs (dicts, arrays, numbers, strings)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), where
        for key in a:
            assert_same_value(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


def policy_record(env, random_policy, steps, seed):
    """Up to ``steps`` steps of a seeded (mask-respecting) random policy: the full step outputs."""
    rng = np.random.default_rng(seed)
    record = []
    for _ in range(steps):
        if not env.agents:
            break
        record.append(env.step(random_policy(env, rng)))
    return record


#: Steps before copying / after copying. A step of Exploration-v0 with operators runs a
#: whole planning stage (often tens of control steps), so it gets fewer of them.
COPY_STEPS = {("Exploration-v0", "operator"): (4, 6), ("Rendezvous-v0", "next_place"): (3, 4)}
#: Settings that keep an episode going long enough to copy it mid-way.
COPY_CONFIG = {"Rendezvous-v0": {"start_places": ("1", "38")}}  # the two ends of the default map (paper 003, Fig. 5)


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize(("env_id", "config"), CASES)
def test_copy_continues_like_original(env_id, config, how, random_policy):
    """A copy made mid-episode continues exactly as the original: observations, rewards, infos.

    Sensor noise makes every step draw from the env's random stream, so the copy must also
    carry the stream's state, not only the simulation's.
    """
    kind = config.get("action_type", getattr(teamgym.env_class(env_id).config_class(), "action_type", None))
    before, after = COPY_STEPS.get((env_id, kind), (15, 20))
    noise = {"sensor_noise": 0.002} if "sensor_noise" in teamgym.env_class(env_id).config_class.field_names() else {}
    env = teamgym.make(env_id, **{**config, "max_cycles": 400, **noise, **COPY_CONFIG.get(env_id, {})})
    env.reset(seed=5)
    policy_record(env, random_policy, before, seed=50)
    assert env.agents, "the episode ended before the copy"
    clone = COPIERS[how](env)
    assert clone is not env and clone.world is not env.world
    np.testing.assert_array_equal(clone.state(), env.state())
    assert clone.agents == env.agents and clone.cycles == env.cycles
    original = policy_record(env, random_policy, after, seed=51)
    copied = policy_record(clone, random_policy, after, seed=51)
    assert len(original) == len(copied) >= min(after, 3)
    for t, (step_a, step_b) in enumerate(zip(original, copied)):
        for name, part_a, part_b in zip(("observations", "rewards", "terminations", "truncations", "infos"), step_a, step_b):
            assert_same_value(part_a, part_b, f"step {t} {name}")


@pytest.mark.parametrize("how", sorted(COPIERS))
def test_copy_in_contact_continues_like_original(how):
    """Copied while shapes overlap (pymunk alone cannot pickle the solver's pending correction)."""
    env = env_mid_episode(in_contact=True)
    clone = COPIERS[how](env)
    assert live_contacts(clone) > 0
    np.testing.assert_array_equal(clone.state(), env.state())
    assert_same_steps(stepping_record(env, 60, seed=1), stepping_record(clone, 60, seed=1))


def test_copy_after_reused_action_buffers():
    """Callers often refill the same float64 arrays each step; a later copy must not see the new values."""
    env = teamgym.make("Navigation-v0", n_robots=3, max_cycles=100)
    env.reset(seed=0)
    buffers = {a: np.zeros(2) for a in env.agents}
    for t in range(20):
        for a in env.agents:
            buffers[a][:] = [0.3, 2.0 * (t % 3 - 1)]
        env.step(buffers)
    for a in env.agents:
        buffers[a][:] = [-0.4, 9.0]
    clone = copy.deepcopy(env)
    np.testing.assert_array_equal(clone.state(), env.state())
    assert_same_steps(stepping_record(env, 50, seed=5), stepping_record(clone, 50, seed=5))


def test_copy_across_resets_and_episode_end():
    env = teamgym.make("Navigation-v0", n_robots=2, max_cycles=5)
    fresh = copy.deepcopy(env)  # before any reset
    assert fresh.world is None and fresh.agents == []
    env.reset(seed=4)
    for _ in range(5):
        env.step({a: np.array([0.2, 0.1], dtype=np.float32) for a in env.agents})
    assert env.agents == []
    ended = pickle.loads(pickle.dumps(env))
    assert ended.agents == [] and ended.cycles == 5
    with pytest.raises(teamgym.EpisodeOverError):
        ended.step({})
    # An unseeded reset continues the RNG stream identically in original and copy.
    obs_a, _ = env.reset()
    obs_b, _ = ended.reset()
    for agent in obs_a:
        np.testing.assert_array_equal(obs_a[agent], obs_b[agent])
    obs_c, _ = fresh.reset(seed=4)
    obs_d, _ = teamgym.make("Navigation-v0", n_robots=2, max_cycles=5).reset(seed=4)
    for agent in obs_c:
        np.testing.assert_array_equal(obs_c[agent], obs_d[agent])


def test_copies_of_a_copy_agree_in_contact():
    """Workers unpickled from the same bytes stay in lock-step (what subprocess vector envs need)."""
    env = env_mid_episode(in_contact=True)
    data = pickle.dumps(env)
    a, b = pickle.loads(data), pickle.loads(data)
    assert_same_steps(stepping_record(a, 60, seed=2), stepping_record(b, 60, seed=2))


def test_copying_does_not_disturb_original():
    untouched = env_mid_episode(in_contact=True)
    copied = env_mid_episode(in_contact=True)
    copy.deepcopy(copied)
    pickle.dumps(copied)
    assert_same_steps(stepping_record(untouched, 50, seed=3), stepping_record(copied, 50, seed=3))


def test_copy_is_independent():
    env = env_mid_episode(in_contact=False)
    clone = copy.deepcopy(env)
    before = env.state().copy()
    stepping_record(clone, 5, seed=4)
    np.testing.assert_array_equal(env.state(), before)
    assert clone.cycles == env.cycles + 5


def test_copy_of_rendering_env_renders():
    env = teamgym.make("Navigation-v0", render_mode="rgb_array", max_cycles=20)
    env.reset(seed=0)
    frame = env.render()
    clone = pickle.loads(pickle.dumps(env))
    np.testing.assert_array_equal(clone.render(), frame)


# -- rendering through the env ---------------------------------------------------------


def test_rgb_array_frames_change_when_robots_move():
    env = teamgym.make("Navigation-v0", render_mode="rgb_array", n_obstacles=0, max_cycles=20)
    env.reset(seed=0)
    first = env.render()
    assert isinstance(first, np.ndarray) and first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    assert np.array_equal(first, env.render())
    for _ in range(5):
        env.step({a: np.array([0.3, 0.0], dtype=np.float32) for a in env.agents})
    later = env.render()
    assert later.shape == first.shape
    assert np.count_nonzero(np.any(later != first, axis=2)) > 100
    env.close()


def test_render_modes():
    assert teamgym.make("Navigation-v0").render() is None
    with pytest.raises(ValueError, match="render_mode"):
        teamgym.make("Navigation-v0", render_mode="ansi")
    env = teamgym.make("Navigation-v0", render_mode="rgb_array")
    with pytest.raises(teamgym.EpisodeOverError, match="reset"):
        env.render()


def test_human_render_is_headless():
    env = teamgym.make("Navigation-v0", render_mode="human", max_cycles=3)
    env.metadata = {**env.metadata, "render_fps": 1000}
    env.reset(seed=0)
    assert env.render() is None
    env.step({a: np.zeros(2, dtype=np.float32) for a in env.agents})
    env.close()


# -- registry ---------------------------------------------------------------------------


def test_registry_lists_navigation():
    ids = teamgym.envs()
    assert "Navigation-v0" in ids
    assert ids == sorted(ids)
    assert teamgym.env_class("Navigation-v0").__name__ == "Navigation"


def test_unknown_env_id_lists_registered_ids():
    with pytest.raises(KeyError) as info:
        teamgym.make("Nope-v0")
    message = str(info.value)
    assert "Nope-v0" in message
    for env_id in teamgym.envs():
        assert env_id in message
    with pytest.raises(KeyError, match="versions available"):
        teamgym.make("Navigation-v9")
    with pytest.raises(KeyError):
        teamgym.make(None)


def test_register_rejects_bad_ids():
    with pytest.raises(ValueError, match="Name-vN"):
        teamgym.register("Navigation", "teamgym.envs.navigation:Navigation")
    with pytest.raises(ValueError, match="already registered"):
        teamgym.register("Navigation-v0", "somewhere.else:Other")
    assert "Navigation" not in teamgym.envs()


def test_navigation_module_entry_points():
    from pettingzoo import AECEnv, ParallelEnv

    from teamgym.envs import navigation

    par = navigation.parallel_env(n_robots=2, max_cycles=5)
    assert isinstance(par, ParallelEnv) and isinstance(par, teamgym.env_class("Navigation-v0"))
    assert par.possible_agents == ["robot_0", "robot_1"]
    aec = navigation.env(n_robots=2, max_cycles=5)
    assert isinstance(aec, AECEnv)
    aec.reset(seed=0)
    assert aec.agent_selection == "robot_0"
    assert isinstance(teamgym.make_aec("Navigation-v0"), AECEnv)
