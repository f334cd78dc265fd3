"""``fixed_agents=True`` (issue 25, deliverable 3): a fixed agent list from reset until the team's episode ends.

Absent robots (spares not yet added, robots after their last step) observe the absent row with
``present`` = 0, get reward 0, report not done until the team ends, keep their infos (with
``present`` = 0) and an all-admissible mask; their actions are ignored.
"""

import copy
import pickle
import warnings

import numpy as np
import pytest
from gymnasium import spaces
from pettingzoo.test import parallel_api_test

import teamgym
from baselines.episode import run_episode
from baselines.registry import make_policy, policies, policy_class, required_config
from teamgym.envs.config import ConfigError
from teamgym.envs.exploration import Exploration

ENV_IDS = teamgym.envs()
DISCRETE_DEFAULT = {"Rendezvous-v0", "Foraging-v0", "BoxPushing-v0", "BoxPushing-v1"}
FORMATS = [(e, f) for e in ENV_IDS for f in ("flat", "dict", "masked") if f != "masked" or e in DISCRETE_DEFAULT]
JOINING = {"fixed_agents": True, "n_spare_robots": 1, "events": ((20, "add_robot"),), "max_cycles": 30}


def _random_actions(env, observations, rng):
    """An in-space action for every agent in ``agents``, admissible where the observation carries a mask."""
    actions = {}
    for agent in env.agents:
        space, observation = env.action_space(agent), observations[agent]
        mask = observation.get("action_mask") if isinstance(observation, dict) else None
        if mask is None and agent in env.action_masks():
            mask = env.action_masks()[agent]
        if mask is not None:
            actions[agent] = int(rng.choice(np.flatnonzero(mask)))
        elif isinstance(space, spaces.Discrete):
            actions[agent] = int(rng.integers(space.n))
        else:
            actions[agent] = rng.uniform(space.low, space.high).astype(np.float32)
    return actions


@pytest.mark.parametrize(("env_id", "obs_format"), FORMATS, ids=[f"{e}-{f}" for e, f in FORMATS])
def test_parallel_api_test_passes_with_fixed_agents(env_id, obs_format):
    env = teamgym.make(env_id, fixed_agents=True, obs_format=obs_format, max_cycles=25)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # the API test warns about agents missing from a step's dicts
        parallel_api_test(env, num_cycles=60)
    assert env.agents == []


MESSAGES = {
    "BoxPushing-v0": {"n_spare_robots": 1, "events": ((5, "add_robot"), (10, "remove_robot", "robot_0"))},
    "Exploration-v0": {"action_type": "operator", "obs_format": "dict"},
}


@pytest.mark.parametrize("env_id", sorted(MESSAGES))
def test_parallel_api_test_passes_with_fixed_agents_and_learned_messages(env_id):
    env = teamgym.make(env_id, fixed_agents=True, comm_dim=2, max_cycles=25, **MESSAGES[env_id])
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        parallel_api_test(env, num_cycles=60)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_agents_stay_the_possible_agents_and_present_is_observed(env_id):
    env = teamgym.make(env_id, fixed_agents=True, max_cycles=15)
    observations, infos = env.reset(seed=0)
    rng = np.random.default_rng(0)
    present = env.layout.slices["present"]
    assert "present" in env.info_schema()
    while env.agents:
        assert env.agents == env.possible_agents
        assert set(observations) == set(infos) == set(env.possible_agents)
        for agent in env.possible_agents:
            assert observations[agent][present] == [float(agent in env.live_agents)]
            assert infos[agent]["present"] == int(agent in env.live_agents)
            assert env.observation_space(agent).contains(observations[agent])
        observations, rewards, terminations, truncations, infos = env.step(_random_actions(env, observations, rng))
        assert set(rewards) == set(terminations) == set(env.possible_agents)
    assert all(terminations[a] or truncations[a] for a in env.possible_agents)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_default_env_has_no_present_field_and_agents_are_the_live_agents(env_id):
    env = teamgym.make(env_id)
    env.reset(seed=0)
    assert "present" not in env.layout.slices and "present" not in env.info_schema()
    assert env.agents is env.live_agents


def _absent_row(env):
    space = env.layout.flat_space()
    row = np.clip(np.zeros(space.shape, np.float32), space.low, space.high)
    row[env.layout.slices["present"]] = 0.0
    return row


def test_a_spare_robot_is_absent_until_it_joins_then_present():
    env = teamgym.make("BoxPushing-v0", **JOINING)
    observations, infos = env.reset(seed=3)
    assert env.agents == ["robot_0", "robot_1", "robot_2"] and env.live_agents == ["robot_0", "robot_1"]
    absent = _absent_row(env)
    rng = np.random.default_rng(0)
    steps = 0
    while env.agents:
        joined = env.cycles >= 20
        assert np.array_equal(observations["robot_2"], absent) != joined
        assert infos["robot_2"]["present"] == int(joined)
        observations, rewards, terminations, truncations, infos = env.step(_random_actions(env, observations, rng))
        steps += 1
        if env.cycles <= 20:  # before it joins, and the step it joins in: no reward of its own
            assert rewards["robot_2"] == 0.0
        if env.agents:
            assert not any(terminations.values()) and not any(truncations.values())
    assert steps == 30
    assert truncations == dict.fromkeys(env.possible_agents, True) and not any(terminations.values())


def test_actions_of_absent_robots_are_optional_and_ignored():
    outcomes = []
    for spare_action in (None, 0, 12):
        env = teamgym.make("BoxPushing-v0", **JOINING)
        env.reset(seed=1)
        trace = []
        for step in range(25):
            actions = {"robot_0": step % 13, "robot_1": (3 * step) % 13}
            if "robot_2" in env.live_agents:
                actions["robot_2"] = step % 13
            elif spare_action is not None:
                actions["robot_2"] = spare_action
            observations, rewards, *_ = env.step(actions)
            trace.append((np.concatenate([observations[a] for a in env.possible_agents]), sorted(rewards.items())))
        outcomes.append(trace)
    for other in outcomes[1:]:
        for (obs_a, rew_a), (obs_b, rew_b) in zip(outcomes[0], other):
            assert np.array_equal(obs_a, obs_b) and rew_a == rew_b


def test_bad_actions_are_refused_before_anything_changes():
    env = teamgym.make("BoxPushing-v0", **JOINING)
    env.reset(seed=0)
    cycles = env.cycles
    with pytest.raises(KeyError, match="robot_9"):
        env.step({"robot_0": 0, "robot_1": 0, "robot_9": 0})
    with pytest.raises(ValueError, match="robot_2"):  # absent, but the action must still be in its space
        env.step({"robot_0": 0, "robot_1": 0, "robot_2": 99})
    with pytest.raises(ValueError, match="robot_1"):  # a live robot must act
        env.step({"robot_0": 0, "robot_2": 0})
    assert env.cycles == cycles and env.live_agents == ["robot_0", "robot_1"]


def _navigation_trace(fixed):
    env = teamgym.make("Navigation-v0", fixed_agents=fixed, max_cycles=150)
    steps = []
    result = run_episode(env, make_policy("goto", env), seed=0, on_step=steps.append, record_trajectories=False)
    return env, result, steps


def test_an_arrived_robot_stays_absent_and_the_episode_is_unchanged():
    env, fixed, steps = _navigation_trace(True)
    _, live, live_steps = _navigation_trace(False)
    assert fixed.length == live.length and fixed.success == live.success
    assert fixed.returns == pytest.approx(live.returns)
    ends = {a: next(s.index for s in live_steps if s.terminations.get(a) or s.truncations.get(a)) for a in env.possible_agents}
    assert len(set(ends.values())) > 1, "the goto robots should arrive at different steps"
    first = min(ends, key=ends.get)
    absent = _absent_row(env)
    for step, step_live in zip(steps, live_steps):
        if step.index < fixed.length:
            assert not step.terminations[first] and not step.truncations[first]
        if step.index <= ends[first]:
            assert np.array_equal(step.observations[first][:-1], step_live.observations[first])  # present: last
        else:
            assert np.array_equal(step.observations[first], absent) and step.rewards[first] == 0.0
            assert step.infos[first]["present"] == 0 and step.infos[first]["arrived"] == 1
    assert steps[-1].terminations[first] and env.agents == []


POLICY_CASES = [(p, e) for p in policies() for e in (policy_class(p).env_ids or ENV_IDS)]
SPARE_EVENTS = {"n_spare_robots": 1, "events": ((15, "add_robot"), (30, "remove_robot", "robot_0"))}


def _episode(policy, env_id, fixed):
    extra = SPARE_EVENTS if env_id.startswith("BoxPushing") else {}
    env = teamgym.make(env_id, fixed_agents=fixed, max_cycles=50, **required_config(policy), **extra)
    return run_episode(env, make_policy(policy, env), seed=0, record_trajectories=False)


@pytest.mark.parametrize(("policy", "env_id"), POLICY_CASES, ids=[f"{p}-{e}" for p, e in POLICY_CASES])
def test_scripted_episodes_are_the_same_with_fixed_agents(policy, env_id):
    fixed, live = _episode(policy, env_id, True), _episode(policy, env_id, False)
    assert (fixed.length, fixed.success, fixed.returns) == (live.length, live.success, live.returns)
    without_present = {a: {k: v for k, v in m.items() if k != "present"} for a, m in fixed.metrics.items()}
    assert without_present == live.metrics
    assert all(m["present"] == 1 for m in fixed.metrics.values())


class _EarlyExit(Exploration):
    """Exploration in which ``robot_0`` ends after the first step (the masked action type has no such case)."""

    def _terminations(self):
        terminations = super()._terminations()
        if self.cycles >= 1 and "robot_0" in terminations:
            terminations["robot_0"] = True
        return terminations


def test_absent_robots_have_all_admissible_masks():
    env = _EarlyExit(action_type="operator", obs_format="dict", fixed_agents=True, max_cycles=60)
    observations, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    observations, _, terminations, _, infos = env.step(_random_actions(env, observations, rng))
    assert not terminations["robot_0"] and observations["robot_0"]["present"] == [1]  # its last step
    masked = [k for k in range(46) if not observations["robot_0"]["action_mask"][k]]
    observations, rewards, _, _, infos = env.step(_random_actions(env, observations, rng))
    for mask in (observations["robot_0"]["action_mask"], infos["robot_0"]["action_mask"], env.action_mask("robot_0")):
        assert np.array_equal(mask, np.ones(46, np.int8))
    assert env.action_masks()["robot_0"].all() and not env.action_masks()["robot_1"].all()
    assert observations["robot_0"]["present"] == [0] and rewards["robot_0"] == 0.0
    actions = _random_actions(env, observations, rng)
    actions["robot_0"] = masked[0]  # inadmissible for a live robot, ignored for an absent one
    env.step(actions)


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_copies_of_an_env_with_absent_robots_continue_identically(how):
    env = teamgym.make("BoxPushing-v0", **JOINING)
    env.reset(seed=2)
    for step in range(10):
        env.step({"robot_0": step % 13, "robot_1": 5, "robot_2": 7})
    clone = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    assert clone.agents == env.agents and clone.live_agents == env.live_agents
    for step in range(15):
        actions = {a: (step + i) % 13 for i, a in enumerate(env.agents)}
        a, b = env.step(actions), clone.step(actions)
        for agent in env.possible_agents:
            assert np.array_equal(a[0][agent], b[0][agent]) and a[1][agent] == b[1][agent]
            assert a[4][agent]["present"] == b[4][agent]["present"]


def test_a_batch_refuses_fixed_agents_naming_the_key():
    """A batch has fixed rows and ``active`` already; ``fixed_agents`` is the PettingZoo face's option."""
    with pytest.raises(teamgym.ConfigError, match="fixed_agents"):
        teamgym.make("Navigation-v0", fixed_agents=True).make_batch(2)
    with pytest.raises(teamgym.ConfigError, match="fixed_agents"):
        teamgym.make_batch("Navigation-v0", 2, fixed_agents=True)


def test_fixed_agents_must_be_a_bool():
    with pytest.raises(ConfigError, match="fixed_agents"):
        teamgym.make("Navigation-v0", fixed_agents="yes")
