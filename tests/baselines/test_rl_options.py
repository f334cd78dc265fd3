"""Config options for learned policies: unit-scaled actions (all envs) and Navigation's local features."""

from __future__ import annotations

import numpy as np
import pytest

import teamgym
from baselines.registry import make_policy
from teamgym.envs.actions import UnitScaled


def run(env, actions_per_step, seed=0):
    observations, _ = env.reset(seed=seed)
    out = [np.stack([observations[a] for a in env.possible_agents])]
    for actions in actions_per_step:
        observations, rewards, *_ = env.step({a: actions[a] for a in env.agents})
        out.append(np.stack([observations[a] for a in env.possible_agents if a in observations]))
        out.append(np.array([rewards[a] for a in sorted(rewards)]))
    return out


@pytest.mark.parametrize(
    ("env_id", "config"), [("Navigation-v0", {"action_type": "velocity"}), ("BoxPushing-v0", {"action_type": "wheels"})]
)
def test_unit_actions_drive_the_robots_like_their_native_values(env_id, config):
    """-1, 0 and 1 map exactly onto low, the middle and high: both envs step bit for bit alike."""
    unit_env = teamgym.make(env_id, normalize_actions=True, max_cycles=30, **config)
    native_env = teamgym.make(env_id, max_cycles=30, **config)
    agents = unit_env.possible_agents
    space = native_env.action_space(agents[0])
    assert unit_env.action_space(agents[0]) == type(space)(-1.0, 1.0, shape=space.shape, dtype=np.float32)
    rng = np.random.default_rng(0)
    unit_steps = [{a: rng.integers(-1, 2, size=space.shape).astype(np.float32) for a in agents} for _ in range(25)]
    native_steps = [
        {a: (space.low + (u[a] + 1) * (space.high - space.low) / 2).astype(np.float32) for a in agents} for u in unit_steps
    ]
    for unit, native in zip(run(unit_env, unit_steps), run(native_env, native_steps), strict=True):
        assert np.array_equal(unit, native)


def test_unit_scaling_round_trips_and_rejects_bad_actions():
    env = teamgym.make("Navigation-v0", normalize_actions=True, action_type="wheels")
    scaled = env.action_type
    assert isinstance(scaled, UnitScaled)
    native = np.array([0.1, -0.3])
    assert np.allclose(scaled.native(scaled.unit(native)), native, atol=1e-6)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_0"):
        env.step({a: np.array([1.5, 0.0], dtype=np.float32) for a in env.agents})  # outside Box(-1, 1)


def test_discrete_actions_cannot_be_unit_scaled():
    with pytest.raises(teamgym.ConfigError, match="normalize_actions=True is invalid; action type 'heading' is not continuous"):
        teamgym.make("Navigation-v0", normalize_actions=True, action_type="heading")


def test_scripted_policies_refuse_unit_actions_and_random_takes_them():
    env = teamgym.make("Navigation-v0", normalize_actions=True)
    with pytest.raises(ValueError, match="'goto' acts in native units"):
        make_policy("goto", env)
    policy = make_policy("random", env)
    policy.reset(0)
    observations, _ = env.reset(seed=0)
    actions = policy.act(observations)
    assert all(np.all(np.abs(a) <= 1) for a in actions.values())


def test_local_features_are_the_world_fields_in_the_robot_frame():
    world = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=2)
    local = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=2, local_features=True)
    rng = np.random.default_rng(1)
    space = world.action_space("robot_0")
    steps = [{a: rng.uniform(space.low, space.high).astype(np.float32) for a in world.possible_agents} for _ in range(20)]
    width = world.observation_space("robot_0").shape[0]
    for plain, extended in zip(run(world, steps), run(local, steps), strict=True):
        if plain.ndim == 2:
            assert np.array_equal(extended[:, :width], plain)  # the paper's fields are untouched
    observations, *_ = local.step({a: steps[0][a] for a in local.agents})
    d = local.decode(observations["robot_1"])
    theta = float(d["pose"][2])
    rotation = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
    assert np.allclose(d["goal_local"], rotation @ d["goal_offset"], atol=1e-5)
    assert np.allclose(d["mates_local"][:, :2], d["mates"][:, :2] @ rotation.T, atol=1e-5)
    assert np.allclose(d["obstacles_local"][:, :2], d["obstacles"][:, :2] @ rotation.T, atol=1e-5)
    assert np.allclose(d["obstacles_local"][:, 2:4], d["obstacles"][:, 2:4] @ rotation.T, atol=1e-5)
    mate_velocity = d["mates"][:, 3:4] * np.stack([np.cos(d["mates"][:, 2]), np.sin(d["mates"][:, 2])], axis=1)
    assert np.allclose(d["mates_local"][:, 2:4], mate_velocity @ rotation.T, atol=1e-5)


@pytest.mark.parametrize("local_features", [False, True])
def test_mate_goals_are_the_mates_goals_relative_to_the_robot(local_features):
    env = teamgym.make("Navigation-v0", n_robots=3, mate_goals=True, local_features=local_features)
    observations, _ = env.reset(seed=4)
    observations, *_ = env.step({a: np.array([0.2, 1.0], dtype=np.float32) for a in env.agents})
    plain_width = teamgym.make("Navigation-v0", n_robots=3, local_features=local_features).observation_space("robot_0").shape[0]
    assert env.observation_space("robot_0").shape[0] == plain_width + 4
    for i, agent in enumerate(env.possible_agents):
        d = env.decode(observations[agent])
        mates = [j for j in range(3) if j != i]
        world = env.goals[mates] - env.robot_positions[i]
        theta = env.robot_headings[i]
        rotation = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
        assert np.allclose(d["mate_goals"], world @ rotation.T if local_features else world, atol=1e-5)


def _in_frame(theta, vector):
    """``vector`` (…, 2) in the frame of a robot with heading ``theta`` (x ahead, y left)."""
    rotation = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
    return vector @ rotation.T


def _encoded(theta, force):
    """A force as field ``forces`` encodes it: unit direction in the robot's frame, log(1 + |F|)."""
    size = np.hypot(*force)
    direction = _in_frame(theta, force) / size if size > 0 else np.zeros(2)
    return np.array([*direction, np.log1p(size)])


def test_virtual_forces_are_paper_001_forces_at_the_robots_pose():
    from teamgym.control.forces import ForceGains

    env = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=2, action_type="heading", virtual_forces=True)
    plain = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=2, action_type="heading")
    assert env.observation_space("robot_0").shape[0] == plain.observation_space("robot_0").shape[0] + 15
    g = ForceGains()
    observations, _ = env.reset(seed=11)
    checked = 0
    for _ in range(60):
        observations, *_ = env.step({a: 2 for a in env.agents})
        for agent in env.agents:
            i = env.possible_agents.index(agent)
            d = env.decode(observations[agent])
            pos, theta = env.robot_positions[i].astype(float), float(env.robot_headings[i])
            to_goal = env.goals[i] - pos
            distance = np.hypot(*to_goal)
            expected = {0: g.k_a / distance**2 * to_goal / distance}  # eq. (15)
            mates = np.zeros(2)
            for j in range(3):
                away = pos - env.robot_positions[j]
                if j != i and np.hypot(*away) < g.influence:  # eq. (19)
                    mates += g.k_r * (1 / np.hypot(*away) - 1 / g.influence) ** 2 * away / np.hypot(*away)
            obstacles = np.zeros(2)
            for centre in env.obstacle_positions + env.obstacle_velocities * env.config.dt:
                away = pos - centre
                if np.hypot(*away) < g.influence:  # eq. (21), the obstacle one step ahead
                    obstacles += g.k_rb * (1 / np.hypot(*away) - 1 / g.influence) ** 2 * away / np.hypot(*away)
            expected.update({1: mates, 2: obstacles})
            for row, force in expected.items():
                assert np.allclose(d["forces"][row], _encoded(theta, force), atol=1e-4), (agent, row)
            checked += bool(np.any(mates) or np.any(obstacles))
            # The sum row is the sum of the four sources (the ray hits included).
            parts = [d["forces"][r, :2] * np.expm1(d["forces"][r, 2]) for r in range(4)]
            total = d["forces"][4, :2] * np.expm1(d["forces"][4, 2])
            assert np.allclose(total, np.sum(parts, axis=0), rtol=1e-3, atol=1e-3)
        if not env.agents:
            break
    assert checked, "no step had a mate or an obstacle within L0: the repulsion rows were not exercised"


def test_virtual_forces_repel_from_a_ray_hit_and_leave_other_fields_unchanged():
    env = teamgym.make("Navigation-v0", n_robots=2, n_obstacles=0, virtual_forces=True, local_features=True)
    plain = teamgym.make("Navigation-v0", n_robots=2, n_obstacles=0, local_features=True)
    obs, _ = env.reset(seed=2)
    ref, _ = plain.reset(seed=2)
    width = plain.observation_space("robot_0").shape[0]
    hit_steps = 0
    for _ in range(80):
        for agent in env.agents:
            assert np.array_equal(obs[agent][:width], ref[agent])
            d = env.decode(obs[agent])
            hits = d["proximity"] < env.config.sensor_range
            assert (d["forces"][3, 2] > 0) == bool(hits.any())
            hit_steps += bool(hits.any())
            if hits.any():  # pushed away from the hit rays: against their mean direction
                rays = np.asarray(env.ring.angles)[hits]
                mean = np.array([np.cos(rays).sum(), np.sin(rays).sum()])
                assert d["forces"][3, :2] @ mean < 0
        actions = {a: np.array([0.3, 0.0], dtype=np.float32) for a in env.agents}
        obs, *_ = env.step(actions)
        ref, *_ = plain.step(actions)
        if not env.agents:
            break
    assert hit_steps, "no ray hit anything: the ray row was not exercised"
