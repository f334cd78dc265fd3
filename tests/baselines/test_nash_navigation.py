"""The game-theoretic navigation baseline of paper 001 (eqs. 12–31)."""

import itertools
import math

import numpy as np
import pytest

import teamgym
from baselines.navigation.game import ForceGains, TeamState, loss_tensor, predict_poses
from baselines.registry import make_policy, required_config
from teamgym.control.heading import nearest_gap

RATES = np.deg2rad([-225.0, -112.5, 0.0, 112.5, 225.0])


def random_state(rng, n, m=2, sensed=True):
    return TeamState(
        positions=rng.uniform(0.5, 1.5, (n, 2)),
        headings=rng.uniform(-np.pi, np.pi, n),
        previous=np.column_stack([rng.uniform(0, 0.25, n), rng.uniform(-3, 3, n)]),
        speeds=rng.uniform(0.1, 0.25, n),
        goals=rng.uniform(0.2, 1.8, (n, 2)),
        static_points=rng.uniform(0.5, 1.5, (1, 2)),
        obstacles=rng.uniform(0.5, 1.5, (m, 2)),
        sensed=[rng.uniform(0.5, 1.5, (int(rng.integers(0, 3)), 2)) for _ in range(n)] if sensed else None,
    )


def test_prediction_follows_eq_17_and_26():
    state = TeamState(
        positions=np.array([[1.0, 2.0]]),
        headings=np.array([0.3]),
        previous=np.array([[0.2, 1.0]]),
        speeds=np.array([0.25]),
        goals=np.zeros((1, 2)),
        static_points=np.zeros((0, 2)),
        obstacles=np.zeros((0, 2)),
    )
    dt, delay = 0.1, 0.04
    predicted, heading = predict_poses(state, RATES, dt, delay)
    for k, w in enumerate(RATES):
        first = 0.3 + 1.0 * delay
        final = first + w * (dt - delay)
        x = 1.0 + 0.2 * delay * math.cos(first) + 0.25 * (dt - delay) * math.cos(final)
        y = 2.0 + 0.2 * delay * math.sin(first) + 0.25 * (dt - delay) * math.sin(final)
        assert predicted[0, k] == pytest.approx([x, y], abs=1e-12)
        assert heading[0, k] == pytest.approx(final)


def brute_force_losses(state, rates, dt, delay, gains):
    """Eq. (25) evaluated joint action by joint action, forces summed as vectors (eqs. 15–24)."""
    predicted, heading = predict_poses(state, rates, dt, delay)
    n, k = len(state.positions), len(rates)

    def push(frm, to, gain):
        offset = to - frm
        d = np.linalg.norm(offset)
        if d >= gains.influence:
            return np.zeros(2)
        return gain * (1 / d - 1 / gains.influence) ** 2 * offset / d

    losses = np.zeros((n,) + (k,) * n)
    for joint in itertools.product(range(k), repeat=n):
        for i in range(n):
            p = predicted[i, joint[i]]
            to_goal = state.goals[i] - p
            force = gains.k_a / np.linalg.norm(to_goal) ** 2 * to_goal / np.linalg.norm(to_goal)
            for j in range(n):
                if j != i:
                    force = force + push(predicted[j, joint[j]], p, gains.k_r)
            for q in state.static_points:
                force = force + push(q, p, gains.k_r)
            for q in state.obstacles:
                force = force + push(q, p, gains.k_rb)
            for q in state.sensed[i] if state.sensed is not None else ():
                force = force + push(q, p, gains.k_rb)
            theta = heading[i, joint[i]]
            # eq. (25): -|F| cos(arg F - theta)
            losses[(i, *joint)] = -np.linalg.norm(force) * math.cos(math.atan2(force[1], force[0]) - theta)
    return losses


@pytest.mark.parametrize("n", [2, 3, 4])
def test_vectorised_losses_match_the_equations(n):
    rng = np.random.default_rng(n)
    gains = ForceGains(k_a=0.5, k_r=1.0, k_rb=4.0, influence=0.6)
    for _ in range(3):
        state = random_state(rng, n)
        rates = RATES[:3] if n == 4 else RATES
        fast, _, _ = loss_tensor(state, rates, 0.2, 0.05, gains)
        np.testing.assert_allclose(fast, brute_force_losses(state, rates, 0.2, 0.05, gains), rtol=1e-9, atol=1e-9)


def test_repulsion_turns_robot_away_from_a_robot_ahead():
    # Robot 0 heads +x towards its goal; robot 1 sits just ahead, slightly to the left.
    state = TeamState(
        positions=np.array([[1.0, 1.0], [1.12, 1.03]]),
        headings=np.array([0.0, np.pi]),
        previous=np.zeros((2, 2)),
        speeds=np.array([0.25, 0.0]),
        goals=np.array([[1.8, 1.0], [1.12, 1.03]]) + [[0, 0], [1e-3, 0]],
        static_points=np.zeros((0, 2)),
        obstacles=np.zeros((0, 2)),
    )
    losses, _, _ = loss_tensor(state, RATES, 0.2, 0.0, ForceGains())
    best = np.unravel_index(np.argmin(losses[0]), losses[0].shape)[0]
    assert RATES[best] < 0  # turn right, away from the robot on the left


def test_nearest_gap_ahead_ignores_objects_behind_and_free_rays():
    ray_angles = np.deg2rad([90, 45, 10, -10, -45, -90, -170, 170])
    offsets = np.array([[-0.2, 0.0], [0.3, 0.0]])  # one behind, one ahead
    gaps = np.array([0.05, 0.2])
    proximity = np.array([0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.02, 0.1])  # back ray sees a wall at 2 cm
    assert nearest_gap(offsets, gaps, 0.0, proximity, ray_angles, 0.1, "ahead") == pytest.approx(0.2)
    assert nearest_gap(offsets, gaps, 0.0, proximity, ray_angles, 0.1, "any") == pytest.approx(0.02)
    assert nearest_gap(offsets[:0], gaps[:0], 0.0, np.full(8, 0.1), ray_angles, 0.1, "any") == np.inf


def test_policy_predicts_the_speed_the_env_applies():
    env = teamgym.make("Navigation-v0", n_robots=3, action_type="heading")
    policy = make_policy("nash", env)
    observations, infos = env.reset(seed=4)
    policy.reset(4)
    for _ in range(30):
        if not env.agents:
            break
        fields = {a: env.decode(observations[a]) for a in env.agents}
        radii = fields[env.agents[0]]["obstacles"][:, 4]
        predicted = {a: policy._speed(fields[a], radii) for a in env.agents}
        actions = policy.act({a: observations[a] for a in env.agents}, infos)
        live = list(env.agents)
        observations, _, _, _, infos = env.step(actions)
        for agent in live:
            assert env.robots[agent].command[0] == pytest.approx(predicted[agent], rel=1e-4, abs=1e-6)


def test_obstacle_prediction_eq23_is_the_position_one_step_ahead():
    # Section 6.3: Δt = 0.2 s; with obstacles on straight lines eq. (23) must land on the
    # obstacle's position at t_n + Δt (from the second step on; the first has no t_{n-1}).
    env = teamgym.make("Navigation-v0", n_robots=2, dt=0.2, walls=False, obstacle_motion="straight", action_type="heading")
    policy = make_policy("nash", env)
    observations, infos = env.reset(seed=5)
    policy.reset(5)
    for robot in env.robots.values():  # keep the robots out of the obstacles' way
        robot.teleport((robot.pose[0] + 10.0, robot.pose[1]), robot.pose[2])
    errors = []
    for _ in range(6):
        actions = policy.act({a: observations[a] for a in env.agents}, infos)
        predicted = policy.predicted_obstacles.copy()
        observations, _, _, _, infos = env.step(actions)
        actual = np.array([o.position for o in env.obstacles])
        errors.append(np.linalg.norm(predicted - actual, axis=1).max())
    assert errors[0] == pytest.approx(0.2 * 0.2, rel=0.05)  # first step: current position, 4 cm behind
    assert max(errors[1:]) < 1e-4


def test_policy_needs_the_heading_action_type():
    env = teamgym.make("Navigation-v0", action_type="velocity")
    with pytest.raises(ValueError, match="heading"):
        make_policy("nash", env)
    assert required_config("nash") == {"action_type": "heading"}


@pytest.mark.parametrize("name", ["nash", "nash-first"])
def test_policy_drives_a_crossing_team_home_without_collisions(name):
    env = teamgym.make("Navigation-v0", n_robots=4, n_obstacles=0, layout="circle", action_type="heading")
    policy = make_policy(name, env)
    observations, infos = env.reset(seed=1)
    policy.reset(1)
    final = {}
    while env.agents:
        observations, _, _, _, infos = env.step(policy.act({a: observations[a] for a in env.agents}, infos))
        final.update(infos)
    assert all(m["arrived"] for m in final.values())
    assert sum(m["collisions"] for m in final.values()) == 0
    assert sum(policy.branch_counts.values()) == len(policy.decision_times) > 0
    assert set(policy.branch_counts) <= {"nash-unique", "nash-arbiter", "minmax-unique", "minmax-arbiter", "single"}


def test_modelled_delay_is_the_env_delay_unless_disabled():
    env = teamgym.make("Navigation-v0", action_type="heading", actuation_delay=0.09)
    assert make_policy("nash", env).delay == pytest.approx(0.09)
    assert make_policy("nash", env, model_delay=False).delay == 0.0


def test_a_modelled_delay_above_dt_is_refused_naming_t0_and_dt():
    env = teamgym.make("Navigation-v0", action_type="heading", actuation_delay=0.15)
    with pytest.raises(ValueError, match=r"T0=0.15 s must be in \[0, dt=0.1\]"):
        make_policy("nash", env)
    assert make_policy("nash", env, model_delay=False).delay == 0.0
    with pytest.raises(ValueError, match="T0=0.12"):
        make_policy("nash", teamgym.make("Navigation-v0", action_type="heading"), delay=0.12)


def test_at_t0_equal_to_dt_eq_26_drops_the_decision_and_every_loss_ties():
    """Eqs. (17), (26) at T0 = Δt: the decision acts for Δt − T0 = 0, so no decision changes any loss."""
    env = teamgym.make("Navigation-v0", action_type="heading", actuation_delay=0.1, n_robots=3)
    policy = make_policy("nash", env)
    assert policy.delay == env.config.dt
    state = TeamState(
        positions=np.array([[0.5, 0.5], [1.5, 0.6], [1.0, 1.4]]),
        headings=np.array([0.3, 2.0, -1.5]),
        previous=np.array([[0.2, 1.0], [0.2, -1.0], [0.1, 0.0]]),
        speeds=np.array([0.25, 0.25, 0.2]),
        goals=np.array([[1.5, 1.5], [0.5, 1.5], [1.0, 0.3]]),
        static_points=np.zeros((0, 2)),
        obstacles=np.array([[1.0, 0.8]]),
    )
    tied, _, _ = loss_tensor(state, policy.rates, 0.1, 0.1, policy.gains)
    for i in range(3):
        np.testing.assert_allclose(tied[i], tied[i].flat[0], rtol=1e-12, atol=1e-12)
    steered, _, _ = loss_tensor(state, policy.rates, 0.1, 0.09, policy.gains)
    assert all(np.ptp(steered[i]) > 1e-6 for i in range(3))
