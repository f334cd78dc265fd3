"""The Beacon example env (``teamgym/envs/examples/beacon.py``): API, messages, episode contract, copies, config."""

import copy
import dataclasses
import math
import pickle

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, render_test
from pettingzoo.utils.conversions import parallel_to_aec

from teamgym.envs.config import ConfigError
from teamgym.envs.examples.beacon import REPORT_BYTES, Beacon, BeaconConfig, env, parallel_env

FORMATS = ["flat", "dict"]
#: The API cases: both observation formats, and a learned message (``comm_dim``) beside the beacon reports.
CASES = {
    "flat": {"obs_format": "flat"},
    "dict": {"obs_format": "dict"},
    "comm": {"obs_format": "dict", "sense_range": 1.0, "comm_dim": 2, "comm_throughput": 0.5, "comm_latency": 1},
}
STILL = np.zeros(2, dtype=np.float32)


def sample(space, rng):
    """A value of a Box or of a Dict of Boxes (motion + learned message), drawn with ``rng``."""
    if hasattr(space, "spaces"):
        return {key: sample(sub, rng) for key, sub in space.spaces.items()}
    return rng.uniform(space.low, space.high).astype(space.dtype)


def random_actions(env, rng):
    return {a: sample(env.action_space(a), rng) for a in env.agents}


# -- PettingZoo API -----------------------------------------------------------------------


@pytest.mark.parametrize("case", CASES)
def test_parallel_api(case):
    parallel_api_test(parallel_env(max_cycles=30, **CASES[case]), num_cycles=40)


@pytest.mark.parametrize("case", CASES)
def test_parallel_seed(case):
    parallel_seed_test(lambda: parallel_env(max_cycles=30, sensor_noise=0.002, **CASES[case]), num_cycles=20)


@pytest.mark.parametrize("case", CASES)
def test_aec_api(case):
    api_test(parallel_to_aec(parallel_env(max_cycles=20, **CASES[case])), num_cycles=20)
    api_test(env(max_cycles=10, **CASES[case]), num_cycles=10)


def test_render_rgb_array():
    def env_fn(render_mode=None):
        aec = env(render_mode=render_mode, max_cycles=10)
        aec.metadata = {**aec.metadata, "render_modes": ["rgb_array"]}  # "human" needs a display
        return aec

    render_test(env_fn)


@pytest.mark.parametrize("case", CASES)
def test_observations_fit_the_space(case):
    e = parallel_env(max_cycles=60, **{"comm_range": 0.8, "sensor_noise": 0.01, **CASES[case]})
    rng = np.random.default_rng(0)
    for seed in range(3):
        observations, _ = e.reset(seed=seed)
        while True:
            for agent, obs in observations.items():
                assert e.observation_space(agent).contains(obs), (agent, obs)
            assert e.state_space.contains(e.state())
            if not e.agents:
                break
            observations, *_ = e.step(random_actions(e, rng))


def test_dict_observation_types():
    e = parallel_env(obs_format="dict", n_robots=4)
    observations, _ = e.reset(seed=0)
    obs = observations["robot_0"]
    assert obs["beacon_seen"].dtype == obs["report_mask"].dtype == np.int8
    assert obs["position"].dtype == obs["reports"].dtype == np.float32
    assert obs["reports"].shape == (3, 2) and obs["report_mask"].shape == (3,)


# -- messages -----------------------------------------------------------------------------

#: robot_0 sees the beacon; robot_1 is 0.6 m from robot_0 (in radio range), robot_2 is far from both.
SCENE = {"beacon": (0.5, 0.5), "starts": [(0.6, 0.5, 0.0), (1.2, 0.5, 0.0), (1.8, 1.8, 0.0)]}
RADIO = {"n_robots": 3, "sense_range": 0.4, "goal_radius": 0.2, "comm_range": 0.8, "obs_format": "dict"}


def step_still(e):
    return e.step({a: STILL for a in e.agents})


def test_report_arrives_in_the_same_step_without_latency():
    e = parallel_env(**RADIO, comm_throughput=1.0, comm_latency=0)
    observations, infos = e.reset(seed=0, options=SCENE)
    assert observations["robot_0"]["beacon_seen"][0] == 1 and observations["robot_1"]["beacon_seen"][0] == 0
    assert not any(obs["report_mask"].any() for obs in observations.values())  # nothing sent at reset
    observations, _, _, _, infos = step_still(e)
    one = observations["robot_1"]
    np.testing.assert_array_equal(one["report_mask"], [1, 0])
    np.testing.assert_allclose(one["reports"][0], SCENE["beacon"])
    assert not observations["robot_0"]["report_mask"].any()  # a broadcast skips its sender
    assert not observations["robot_2"]["report_mask"].any()  # out of range
    assert infos["robot_0"]["bytes_sent"] == REPORT_BYTES and infos["robot_1"]["bytes_delivered"] == REPORT_BYTES
    assert infos["robot_0"]["dropped_range"] == 1


def test_report_arrives_one_step_later_with_latency():
    e = parallel_env(**RADIO, comm_throughput=1.0, comm_latency=1)
    e.reset(seed=0, options=SCENE)
    observations, *_ = step_still(e)
    assert not observations["robot_1"]["report_mask"].any()
    observations, *_ = step_still(e)
    np.testing.assert_array_equal(observations["robot_1"]["report_mask"], [1, 0])
    np.testing.assert_allclose(observations["robot_1"]["reports"][0], SCENE["beacon"])


def test_nothing_arrives_without_throughput():
    e = parallel_env(**RADIO, comm_throughput=0.0)
    e.reset(seed=0, options=SCENE)
    for _ in range(3):
        observations, _, _, _, infos = step_still(e)
        assert not any(obs["report_mask"].any() for obs in observations.values())
    assert infos["robot_0"]["messages_sent"] == 3 and infos["robot_0"]["dropped_loss"] == 3
    assert all(info["bytes_delivered"] == 0 for info in infos.values())


def test_learned_messages_and_reports_share_the_channel_apart():
    e = parallel_env(**RADIO, comm_dim=2)
    e.reset(seed=0, options=SCENE)
    message = np.array([0.5, -0.5], dtype=np.float32)
    observations, _, _, _, infos = e.step({a: {"motion": STILL, "message": message} for a in e.agents})
    one = observations["robot_1"]
    np.testing.assert_array_equal(one["report_mask"], [1, 0])  # only kind "beacon"
    np.testing.assert_allclose(one["reports"][0], SCENE["beacon"])
    np.testing.assert_array_equal(one["inbox_mask"], [1, 0])  # only kind "learned": robot_0's message
    np.testing.assert_array_equal(one["inbox"][0], message)
    assert infos["robot_0"]["bytes_sent"] == REPORT_BYTES + message.nbytes


def test_flat_observation_decodes_to_the_same_report():
    e = parallel_env(**{**RADIO, "obs_format": "flat"})
    e.reset(seed=0, options=SCENE)
    observations, *_ = step_still(e)
    fields = e.decode(observations["robot_1"])
    np.testing.assert_array_equal(fields["report_mask"], [1, 0])
    np.testing.assert_allclose(fields["reports"][0], SCENE["beacon"])


def test_bad_reset_options_are_refused():
    e = parallel_env()
    with pytest.raises(ValueError, match="beacon"):
        e.reset(seed=0, options={"beacon": (5.0, 0.5)})
    with pytest.raises(ValueError, match="starts"):
        e.reset(seed=0, options={"starts": [(0.5, 0.5, 0.0)]})


# -- episode contract ---------------------------------------------------------------------


class GoToBeacon:
    """Scripted policy on the observations alone: head for the beacon seen or reported, else patrol."""

    def __init__(self, env):
        self.env = env
        s = env.config.arena_size
        self.patrol = [(0.25 * s, 0.25 * s), (0.75 * s, 0.25 * s), (0.75 * s, 0.75 * s), (0.25 * s, 0.75 * s)]
        self.waypoint = {a: i % 4 for i, a in enumerate(env.possible_agents)}
        self.known = {}

    def __call__(self, observations):
        actions = {}
        for agent, obs in observations.items():
            f = self.env.decode(obs)
            position, theta = f["position"].astype(float), float(f["heading"][0])
            if f["beacon_seen"][0]:
                self.known[agent] = position + f["beacon_offset"]
            elif f["report_mask"].any():
                self.known[agent] = f["reports"][int(np.argmax(f["report_mask"]))].astype(float)
            if agent in self.known:
                target, stop = self.known[agent], 0.4 * self.env.config.goal_radius
            else:
                target, stop = np.array(self.patrol[self.waypoint[agent]]), 0.1
                if np.linalg.norm(target - position) < stop:
                    self.waypoint[agent] = (self.waypoint[agent] + 1) % 4
            offset = target - position
            error = math.remainder(math.atan2(offset[1], offset[0]) - theta, 2 * math.pi)
            v = 0.0 if np.linalg.norm(offset) < stop else 0.3 * max(math.cos(error), 0.0)
            actions[agent] = np.array([v, np.clip(5.0 * error, -5.0, 5.0)], dtype=np.float32)
        return actions


def run_scripted(e, seed):
    """Steps of a scripted episode; checks the contract at every step. Returns the last infos."""
    policy = GoToBeacon(e)
    observations, infos = e.reset(seed=seed)
    assert all(info["success"] == e.episode_success() for info in infos.values())
    while e.agents:
        observations, _, terminations, _, infos = e.step(policy(observations))
        assert all(info["success"] == e.episode_success() for info in infos.values())
        assert all(t == e.episode_success() for t in terminations.values())
    return infos


@pytest.mark.parametrize("obs_format", FORMATS)
def test_scripted_policy_reaches_the_beacon_on_most_seeds(obs_format):
    e = parallel_env(obs_format=obs_format, max_cycles=400, comm_range=1.5)
    results = [all(info["success"] for info in run_scripted(e, seed).values()) for seed in range(5)]
    assert sum(results) >= 4, results


def test_reports_speed_the_team_up():
    """The same scripted team gathers sooner when the robots that see the beacon are heard."""
    cycles = {}
    for throughput in (0.0, 1.0):
        e = parallel_env(max_cycles=400, comm_throughput=throughput)
        for seed in range(3):
            run_scripted(e, seed)
            cycles.setdefault(throughput, []).append(e.cycles)
    assert sum(cycles[1.0]) < sum(cycles[0.0]), cycles


def test_random_episode_keeps_the_contract():
    e = parallel_env(max_cycles=40)
    rng = np.random.default_rng(3)
    _, infos = e.reset(seed=3)
    while e.agents:
        _, rewards, _, _, infos = e.step(random_actions(e, rng))
        assert all(isinstance(r, float) and np.isfinite(r) for r in rewards.values())
        assert all(info["success"] == e.episode_success() for info in infos.values())
        assert all(isinstance(v, (int, float)) for info in infos.values() for v in info.values())


# -- copies -------------------------------------------------------------------------------


def same(a, b, where=""):
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for key in a:
            same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, tuple):
        for i, (part_a, part_b) in enumerate(zip(a, b, strict=True)):
            same(part_a, part_b, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


@pytest.mark.parametrize("options", [None, SCENE], ids=["random", "scripted-scene"])
@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_copy_mid_episode_continues_identically(how, options):
    e = parallel_env(**RADIO, comm_throughput=0.5, comm_latency=1, sensor_noise=0.002, max_cycles=200)
    e.reset(seed=5, options=options)
    rng = np.random.default_rng(50)
    for _ in range(15):
        e.step(random_actions(e, rng))
    clone = copy.deepcopy(e) if how == "deepcopy" else pickle.loads(pickle.dumps(e))
    np.testing.assert_array_equal(clone.state(), e.state())
    for t in range(20):
        actions = random_actions(e, rng)
        same(e.step(actions), clone.step(actions), f"step {t}")


# -- config -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("n_robots", 0),
        ("n_robots", 17),
        ("goal_radius", 0.6),  # > sense_range: robots at the beacon would not see it
        ("sense_range", -1.0),
        ("time_penalty", -0.1),
        ("comm_latency", -1),
    ],
)
def test_invalid_config_is_refused_everywhere(key, value):
    with pytest.raises(ConfigError, match=key):
        Beacon(**{key: value})
    with pytest.raises(ConfigError, match=key):
        parallel_env(**{key: value})
    with pytest.raises(ConfigError, match=key):
        dataclasses.replace(BeaconConfig(), **{key: value})


def test_config_rejects_unknown_keys_and_wrong_types():
    with pytest.raises(ConfigError, match="unknown"):
        parallel_env(n_robot=3)
    with pytest.raises(ConfigError, match="n_robots"):
        BeaconConfig(n_robots=2.5)
