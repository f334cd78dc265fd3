"""Navigation-v0: configuration, observations, rewards, arrival and the heading action of paper 001."""

import dataclasses
import math

import numpy as np
import pytest
from gymnasium import spaces

import teamgym
from teamgym.control.heading import HeadingHeuristic
from teamgym.envs.navigation import NavigationConfig

# -- configuration -------------------------------------------------------------------

EVERY_KEY = dict(
    max_cycles=50,
    dt=0.05,
    substeps=10,
    coarse_substeps=4,
    mate_goals=True,
    n_robots=4,
    n_obstacles=3,
    arena_size=1.5,
    layout="circle",
    robot_radius=0.03,
    max_wheel_speed=0.35,
    max_motor_force=0.8,
    obstacle_speed=0.15,
    obstacle_radius=0.07,
    action_type="heading",
    heading_levels=7,
    heading_max_rate=180.0,
    v_opt=0.2,
    alpha=80.0,
    beta=30.0,
    target_threshold=0.04,
    object_threshold=0.12,
    speed_rule="any",
    walls=False,
    obstacle_motion="straight",
    actuation_delay=0.02,
    true_delay="fixed",
    goal_tolerance=0.04,
    min_goal_distance=0.5,
    spawn_margin=0.1,
    sensor_range=0.08,
    sensor_noise=0.002,
    progress_reward=5.0,
    collision_penalty=2.0,
    arrival_bonus=20.0,
    time_penalty=0.02,
    local_features=True,
    virtual_forces=True,
    obs_format="dict",
    comm_dim=2,
    comm_range=1.0,
    comm_throughput=0.5,
    comm_latency=1,
    comm_byte_budget=64,
    fixed_agents=True,
)


def test_every_documented_key_is_covered():
    # normalize_actions needs a continuous action type (tests/baselines/test_rl_options.py covers it)
    assert set(EVERY_KEY) | {"normalize_actions"} == set(NavigationConfig.field_names())
    defaults = NavigationConfig()
    for key, value in EVERY_KEY.items():
        assert getattr(defaults, key) != value, f"{key}: pick a non-default value"


def test_make_with_every_key():
    env = teamgym.make("Navigation-v0", **EVERY_KEY)
    assert env.config.as_dict() == {**EVERY_KEY, "normalize_actions": False}
    observations, _ = env.reset(seed=0)
    assert env.possible_agents == [f"robot_{i}" for i in range(4)]
    assert len(env.obstacles) == 3
    assert env.world.size == (1.5, 1.5) and env.world.dt == 0.05 and env.world.substeps == 10 and env.world.coarse_substeps == 4
    assert all(r.spec.radius == 0.03 and r.spec.max_motor_force == 0.8 for r in env.robots.values())
    assert env.action_space("robot_0")["motion"] == spaces.Discrete(7)
    assert env.action_space("robot_0")["message"].shape == (2,)
    assert env.observation_space("robot_0")["inbox"].shape == (3, 2)
    assert all(o.bounding_radius == pytest.approx(0.07) for o in env.obstacles)
    assert all(math.hypot(*o.velocity) == pytest.approx(0.15) for o in env.obstacles)
    # circle layout: goals are the antipodes of the starts about the arena centre
    starts = np.array([r.pose[:2] for r in env.robots.values()])
    np.testing.assert_allclose(starts + env.goals, 1.5, atol=1e-9)
    assert env.decode(observations["robot_0"])["radius"] == pytest.approx(0.03)
    assert np.all(env.decode(observations["robot_0"])["proximity"] <= np.float32(0.08))
    received = 0
    for _ in range(50):
        message = np.full(2, 0.5, dtype=np.float32)
        observations, _, _, truncations, infos = env.step({a: {"motion": 3, "message": message} for a in env.agents})
        received += sum(int(o["inbox_mask"].sum()) for o in observations.values())
    assert env.agents == [] and all(truncations.values())
    assert received > 0 and all(info["bytes_sent"] == 8 * 50 for info in infos.values())


def test_string_values_are_parsed():
    env = teamgym.make("Navigation-v0", n_robots="5", arena_size="1.5", layout="circle", dt="0.05")
    assert env.config.n_robots == 5 and env.config.arena_size == 1.5 and env.config.dt == 0.05
    assert env.config.layout == "circle"
    assert isinstance(env.config.arena_size, float)
    assert teamgym.make("Navigation-v0", arena_size=2).config.arena_size == 2.0


BAD_CONFIGS = [
    ({"n_robot": 3}, ["n_robot", "n_robots"]),  # unknown key, valid keys listed
    ({"n_robots": 0}, ["n_robots", "0"]),
    ({"n_robots": 65}, ["n_robots", "65"]),
    ({"n_robots": 2.5}, ["n_robots", "2.5", "int"]),
    ({"n_robots": True}, ["n_robots", "True"]),
    ({"n_robots": "three"}, ["n_robots", "three"]),
    ({"n_robots": None}, ["n_robots", "None"]),
    ({"n_obstacles": -1}, ["n_obstacles", "-1"]),
    ({"arena_size": 0.4}, ["arena_size", "0.4"]),
    ({"arena_size": math.nan}, ["arena_size", "nan"]),
    ({"arena_size": math.inf}, ["arena_size", "inf"]),
    ({"layout": "grid"}, ["layout", "grid"]),
    ({"action_type": "torque"}, ["action_type", "torque"]),
    ({"dt": 0.0}, ["dt", "0.0"]),
    ({"substeps": 0}, ["substeps", "0"]),
    ({"max_cycles": 0}, ["max_cycles", "0"]),
    ({"actuation_delay": 0.81}, ["actuation_delay", "0.81"]),
    ({"actuation_delay": -0.01}, ["actuation_delay", "-0.01"]),
    ({"true_delay": "exact"}, ["true_delay", "exact"]),
    ({"v_opt": 0.5}, ["v_opt", "0.5"]),
    ({"robot_radius": 0.001}, ["robot_radius", "0.001"]),
    ({"max_wheel_speed": 0.0}, ["max_wheel_speed", "0.0"]),
    ({"max_motor_force": -1.0}, ["max_motor_force", "-1.0"]),
    ({"obstacle_speed": -0.1}, ["obstacle_speed", "-0.1"]),
    ({"obstacle_radius": 1.0}, ["obstacle_radius", "1.0"]),
    ({"heading_levels": 1}, ["heading_levels", "1"]),
    ({"heading_max_rate": 0.0}, ["heading_max_rate", "0.0"]),
    ({"goal_tolerance": 0.0}, ["goal_tolerance", "0.0"]),
    ({"min_goal_distance": 2.0}, ["min_goal_distance", "2.0"]),
    ({"sensor_range": 0.0}, ["sensor_range", "0.0"]),
    ({"sensor_noise": -0.1}, ["sensor_noise", "-0.1"]),
    ({"obstacle_motion": "straight"}, ["obstacle_motion", "straight", "walls=False"]),  # walls would stop it
    ({"obstacle_motion": "zigzag"}, ["obstacle_motion", "zigzag"]),
    ({"walls": "maybe"}, ["walls", "maybe"]),
    ({"n_robots": 64, "arena_size": 1.0}, ["n_robots", "64", "room"]),  # arena too small for the team
]


@pytest.mark.parametrize(("config", "fragments"), BAD_CONFIGS, ids=[str(c) for c, _ in BAD_CONFIGS])
def test_invalid_config_fails_at_make(config, fragments):
    with pytest.raises(teamgym.ConfigError) as info:
        teamgym.make("Navigation-v0", **config)
    assert isinstance(info.value, ValueError)
    for fragment in fragments:
        assert fragment in str(info.value), f"{fragment!r} not in {str(info.value)!r}"


@pytest.mark.parametrize(
    "config",
    [
        dict(arena_size=0.5, min_goal_distance=0.3),
        dict(n_robots=40, arena_size=0.8, n_obstacles=6, min_goal_distance=0.2),
        dict(arena_size=0.8, n_robots=6),
    ],
    ids=["small-arena", "crowded-arena", "goals-too-far"],
)
def test_config_that_cannot_be_placed_fails_at_make(config):
    with pytest.raises(teamgym.ConfigError, match="could not place|too little room"):
        teamgym.make("Navigation-v0", **config)


@pytest.mark.parametrize(
    "config",
    [
        dict(arena_size=0.8, n_robots=4, min_goal_distance=0.3),
        dict(n_robots=10, arena_size=0.8, n_obstacles=2, min_goal_distance=0.2),
    ],
)
def test_tight_config_accepted_at_make_resets_on_every_seed(config):
    env = teamgym.make("Navigation-v0", **config)  # make() tried seeds 0-31
    for seed in range(32, 44):
        env.reset(seed=seed)


def test_config_is_frozen():
    env = teamgym.make("Navigation-v0")
    with pytest.raises(dataclasses.FrozenInstanceError):
        env.config.n_robots = 7


# -- observations ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def stepped_env():
    env = teamgym.make("Navigation-v0", n_robots=4, n_obstacles=3, max_cycles=100)
    env.reset(seed=6)
    rng = np.random.default_rng(6)
    for _ in range(10):
        commands = {a: np.array([rng.uniform(0, 0.3), rng.uniform(-2, 2)], dtype=np.float32) for a in env.agents}
        observations, *_ = env.step(commands)
    return env, observations, commands


def test_observation_fields_match_the_world(stepped_env):
    env, observations, commands = stepped_env
    n, m = env.config.n_robots, env.config.n_obstacles
    for i, agent in enumerate(env.possible_agents):
        fields = env.decode(observations[agent])
        assert set(fields) == {"pose", "velocity", "last_command", "radius", "goal_offset", "mates", "obstacles", "proximity"}
        robot = env.robots[agent]
        x, y, theta = robot.pose
        np.testing.assert_allclose(fields["pose"], [x, y, theta], atol=1e-6)
        np.testing.assert_allclose(fields["velocity"], robot.velocity, atol=1e-5)
        np.testing.assert_allclose(fields["last_command"], commands[agent], atol=1e-6)
        assert fields["radius"] == pytest.approx(env.config.robot_radius)
        np.testing.assert_allclose(fields["goal_offset"], env.goals[i] - [x, y], atol=1e-6)
        mates = [a for a in env.possible_agents if a != agent]
        assert fields["mates"].shape == (n - 1, 5)
        for row, mate in zip(fields["mates"], mates):
            other = env.robots[mate]
            np.testing.assert_allclose(row[:2], np.array(other.pose[:2]) - [x, y], atol=1e-6)
            np.testing.assert_allclose(row[2:], [other.pose[2], *other.velocity], atol=1e-5)
        assert fields["obstacles"].shape == (m, 5)
        for row, obstacle in zip(fields["obstacles"], env.obstacles):
            np.testing.assert_allclose(row[:2], np.array(obstacle.position) - [x, y], atol=1e-6)
            np.testing.assert_allclose(row[2:4], obstacle.velocity, atol=1e-6)
            assert row[4] == pytest.approx(obstacle.bounding_radius)
        np.testing.assert_allclose(fields["proximity"], env.ring.read(robot, env.world.space), atol=1e-6)


def test_state_layout(stepped_env):
    env, _, _ = stepped_env
    state = env.state()
    n = env.config.n_robots
    robots = state[: 7 * n].reshape(n, 7)
    for row, robot, goal in zip(robots, env.robots.values(), env.goals):
        np.testing.assert_allclose(row[:3], robot.pose, atol=1e-6)
        np.testing.assert_allclose(row[5:7], goal, atol=1e-6)
    obstacles = state[7 * n :].reshape(-1, 4)
    for row, obstacle in zip(obstacles, env.obstacles):
        np.testing.assert_allclose(row[:2], obstacle.position, atol=1e-6)


def test_proximity_sees_arena_wall():
    env = teamgym.make("Navigation-v0", n_robots=1, n_obstacles=0)
    env.reset(seed=0)
    robot = env.robots["robot_0"]
    robot.teleport((env.config.robot_radius + 0.04, 1.0), math.pi / 2)  # west wall 4 cm to the robot's left
    observations, *_ = env.step({"robot_0": np.zeros(2, dtype=np.float32)})
    proximity = env.decode(observations["robot_0"])["proximity"]
    assert proximity[0] == pytest.approx(0.04, abs=1e-3)
    assert proximity[5] == pytest.approx(env.config.sensor_range)


# -- workspace: walls and obstacle paths (paper 001's open workspace) ----------------------


def test_open_workspace_has_no_walls_and_robots_may_leave_the_square():
    env = teamgym.make("Navigation-v0", n_robots=1, n_obstacles=0, walls=False, max_cycles=100)
    env.reset(seed=0)
    assert not any(name.startswith("wall") for name in env.world.entities)
    robot = env.robots["robot_0"]
    robot.teleport((env.config.robot_radius + 0.04, 1.0), math.pi)  # facing west, 4 cm from the square's edge
    observations, *_ = env.step({"robot_0": np.zeros(2, dtype=np.float32)})
    assert np.all(env.decode(observations["robot_0"])["proximity"] == np.float32(env.config.sensor_range))
    for _ in range(10):
        _, _, _, _, infos = env.step({"robot_0": np.array([0.3, 0.0], dtype=np.float32)})
    assert robot.pose[0] < -0.2  # drove out of the square, nothing in the way
    assert infos["robot_0"]["collisions"] == 0


def test_walled_arena_is_the_default():
    env = teamgym.make("Navigation-v0", n_robots=1, n_obstacles=0)
    env.reset(seed=0)
    assert {"wall_south", "wall_east", "wall_north", "wall_west"} <= set(env.world.entities)


def _obstacle_track(config, steps=60):
    env = teamgym.make("Navigation-v0", n_robots=1, n_obstacles=2, max_cycles=steps + 1, dt=0.2, **config)
    env.reset(seed=3)
    env.robots["robot_0"].teleport((-5.0, -5.0), 0.0)  # out of the obstacles' way
    track = []
    for _ in range(steps):
        env.step({"robot_0": np.zeros(2, dtype=np.float32)})
        track.append(np.array([o.position for o in env.obstacles]))
    return env, np.array(track)


def test_straight_obstacles_keep_their_velocity_and_leave_the_square():
    env, track = _obstacle_track({"walls": False, "obstacle_motion": "straight"})
    steps = np.diff(track, axis=0)  # (T-1, M, 2) displacement per 0.2 s step
    np.testing.assert_allclose(np.linalg.norm(steps, axis=2), 0.2 * 0.2, rtol=1e-3)
    np.testing.assert_allclose(steps, np.broadcast_to(steps[0], steps.shape), atol=1e-4)  # never turns
    outside = (track < 0) | (track > env.config.arena_size)
    assert outside.any(axis=(0, 2)).all()  # 12 s at 20 cm/s: every obstacle has left the 2 m square
    # eq. (23) from successive positions predicts the next one exactly
    np.testing.assert_allclose(2 * track[1:-1] - track[:-2], track[2:], atol=1e-4)


def test_straight_obstacles_cross_the_middle_of_the_square():
    size = 2.0
    lo, hi = 0.25 * size, 0.75 * size
    for seed in range(20):
        env = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=2, walls=False, obstacle_motion="straight")
        env.reset(seed=seed)
        for obstacle in env.obstacles:
            start = np.array(obstacle.position)
            heading = np.array(obstacle.target_velocity) / env.config.obstacle_speed
            # the line start + t·heading (t >= 0) passes through the middle half of the square
            t = np.linspace(0.0, 3 * size, 601)
            line = start[None, :] + t[:, None] * heading[None, :]
            inside = np.all((line >= lo) & (line <= hi), axis=1)
            assert inside.any(), (seed, obstacle.name, start, heading)


@pytest.mark.parametrize("walls", [True, False])
def test_bouncing_obstacles_stay_in_the_square_with_or_without_walls(walls):
    env, track = _obstacle_track({"walls": walls, "obstacle_motion": "bounce"})
    size, radius = env.config.arena_size, env.config.obstacle_radius
    assert track.min() > -1e-3 and track.max() < size + 1e-3
    assert (track.min(axis=(0, 2)) < radius + 0.05).any() or (track.max(axis=(0, 2)) > size - radius - 0.05).any()
    turns = np.einsum("tmk,tmk->tm", np.diff(track, axis=0)[1:], np.diff(track, axis=0)[:-1]) < 0
    assert turns.any()  # some obstacle reflected at the square's edge


# -- rewards, arrival, metrics ------------------------------------------------------------


def test_reward_is_progress_minus_time():
    env = teamgym.make("Navigation-v0", n_robots=2, n_obstacles=0, max_cycles=20)
    _, infos = env.reset(seed=2)
    c = env.config
    for _ in range(5):
        _, rewards, _, _, new_infos = env.step({a: np.array([0.2, 0.3], dtype=np.float32) for a in env.agents})
        for agent in env.possible_agents:
            assert new_infos[agent]["collisions"] == 0
            progress = infos[agent]["distance_to_goal"] - new_infos[agent]["distance_to_goal"]
            assert rewards[agent] == pytest.approx(c.progress_reward * progress - c.time_penalty, abs=1e-9)
        infos = new_infos


def test_collision_is_penalised_and_counted():
    env = teamgym.make("Navigation-v0", n_robots=1, n_obstacles=0, max_cycles=100)
    _, infos = env.reset(seed=0)
    c = env.config
    unexplained = 0.0
    while env.agents:
        _, rewards, _, _, new_infos = env.step({"robot_0": np.array([0.4, 0.0], dtype=np.float32)})  # into a wall
        progress = infos["robot_0"]["distance_to_goal"] - new_infos["robot_0"]["distance_to_goal"]
        unexplained += c.progress_reward * progress - c.time_penalty - rewards["robot_0"]
        infos = new_infos
    collisions = infos["robot_0"]["collisions"]
    assert collisions >= 1
    assert unexplained == pytest.approx(collisions * c.collision_penalty, abs=1e-9)


def go_home(env, agent, observations, steps=400):
    omega_max = float(env.action_space(agent).high[1])
    for _ in range(steps):
        fields = env.decode(observations[agent])
        gx, gy = fields["goal_offset"]
        error = math.remainder(math.atan2(gy, gx) - fields["pose"][2], math.tau)
        command = [0.3 * max(math.cos(error), 0.0), float(np.clip(6 * error, -omega_max, omega_max))]
        actions = {a: np.zeros(2, dtype=np.float32) for a in env.agents}
        actions[agent] = np.array(command, dtype=np.float32)
        observations, rewards, terminations, truncations, infos = env.step(actions)
        if terminations[agent]:
            return rewards, terminations, truncations, infos
    raise AssertionError(f"{agent} did not arrive")


def test_arrival_terminates_with_bonus_and_stops_the_robot():
    env = teamgym.make("Navigation-v0", n_robots=2, n_obstacles=0, arena_size=1.0, min_goal_distance=0.3)
    observations, _ = env.reset(seed=3)
    rewards, terminations, truncations, infos = go_home(env, "robot_0", observations)
    info = infos["robot_0"]
    assert terminations == {"robot_0": True, "robot_1": False}
    assert not any(truncations.values())
    assert info["arrived"] and info["distance_to_goal"] < env.config.goal_tolerance
    assert info["time_to_goal"] == pytest.approx(env.cycles * env.config.dt)
    assert rewards["robot_0"] > env.config.arrival_bonus - 1
    assert env.agents == ["robot_1"]
    robot = env.robots["robot_0"]
    assert robot.command == (0.0, 0.0)
    for _ in range(5):
        _, rewards, *_ = env.step({"robot_1": np.zeros(2, dtype=np.float32)})
        assert set(rewards) == {"robot_1"}
    assert robot.space is env.world.space  # it stays in the world as an obstacle
    assert np.hypot(*(np.array(robot.pose[:2]) - env.goals[0])) < env.config.goal_tolerance + 0.01


def test_metrics_are_consistent():
    env = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=2, max_cycles=30)
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    previous = None
    while env.agents:
        _, _, _, _, infos = env.step({a: rng.uniform(-1, 1, 2).astype(np.float32) * [0.3, 3] for a in env.agents})
        for agent, info in infos.items():
            assert info["min_center_distance"] >= info["min_clearance"] + 2 * env.config.robot_radius - 1e-9
            assert info["path_length"] >= 0 and info["smoothness"] >= 0
            if previous is not None:
                assert info["path_length"] >= previous[agent]["path_length"]
                assert info["min_clearance"] <= previous[agent]["min_clearance"]
        previous = infos
    trail = env.trajectories()["robot_0"]
    assert len(trail) == 31
    steps = np.hypot(*np.diff(np.array(trail), axis=0).T).sum()
    assert previous["robot_0"]["path_length"] == pytest.approx(steps, rel=1e-6)


# -- heading action (eqs. 11-13) ----------------------------------------------------------


def test_heading_heuristic_eq12():
    h = HeadingHeuristic()
    assert h.speed(np.inf, np.inf) == pytest.approx(h.v_opt)
    assert h.speed(h.target_threshold, np.inf) == pytest.approx(h.v_opt / 2)
    assert h.speed(np.inf, h.object_threshold) == pytest.approx(0.75 * h.v_opt)
    assert h.speed(0.0, np.inf) == pytest.approx(h.v_opt / (1 + math.exp(5.0)))
    assert h.speed(0.10, 1.0) > 0.99 * h.v_opt * (1 + 1 / (1 + math.exp(-40 * 0.85))) / 2
    distances = np.array([0.0, 0.05, 0.1, 1.0])
    np.testing.assert_allclose(h.speed(distances, np.inf), [h.speed(d, np.inf) for d in distances])
    assert np.all(np.diff(h.speed(distances, 0.3)) > 0)


def test_heading_levels_are_eq11_set():
    env = teamgym.make("Navigation-v0", action_type="heading", n_robots=1, n_obstacles=0)
    env.reset(seed=0)
    assert env.action_space("robot_0") == spaces.Discrete(5)
    rates = []
    for k in range(5):
        env.step({"robot_0": k})
        v, omega = env.robots["robot_0"].command
        assert 0 < v <= env.config.v_opt
        rates.append(omega)
    np.testing.assert_allclose(np.rad2deg(rates), [-225, -112.5, 0, 112.5, 225])


def test_heading_speed_in_open_space_is_v_opt():
    env = teamgym.make("Navigation-v0", action_type="heading", n_robots=1, n_obstacles=0, layout="circle")
    observations, infos = env.reset(seed=0)
    assert infos["robot_0"]["distance_to_goal"] > 1.0
    assert np.all(env.decode(observations["robot_0"])["proximity"] == np.float32(env.config.sensor_range))
    env.step({"robot_0": 2})
    v, omega = env.robots["robot_0"].command
    assert omega == 0.0
    assert v == pytest.approx(env.config.v_opt, rel=0.02)


# -- actuation delays past one step (section 6.1 carried on) ---------------------------


def test_delays_up_to_eight_steps_are_accepted_and_fixed_true_delay_is_t0():
    assert NavigationConfig.MAX_DELAY_STEPS == 8
    env = teamgym.make("Navigation-v0", actuation_delay=0.8, n_obstacles=0)
    assert env.config.actuation_delay == 0.8
    fixed = teamgym.make("Navigation-v0", actuation_delay=0.07, true_delay="fixed", n_obstacles=0)
    fixed.reset(seed=0)
    state = fixed.np_random.bit_generator.state
    fixed.step({a: fixed.action_space(a).sample() * 0 for a in fixed.agents})
    assert [r.actuation_delay for r in fixed.robot_list] == [0.07] * fixed.config.n_robots
    assert fixed.np_random.bit_generator.state == state  # "fixed" draws no δt


@pytest.mark.parametrize("true_delay", ["random", "fixed"])
def test_copies_and_pickles_with_a_command_queue_go_on_bit_for_bit(monkeypatch, true_delay):
    import pickle

    monkeypatch.setattr(teamgym.env_class("Navigation-v0"), "rebase_cycles", 4)  # the queue crosses re-bases
    env = teamgym.make("Navigation-v0", actuation_delay=0.25, true_delay=true_delay, n_robots=3, max_cycles=40)
    env.reset(seed=2)
    plan = [{a: env.action_space(a).sample() for a in env.possible_agents} for _ in range(30)]
    for actions in plan[:10]:
        env.step({a: actions[a] for a in env.agents})
    assert all(len(r.given_commands) == 4 for r in env.robot_list)  # ⌊2.5⌋ + 2 commands kept
    twins = [env.copy(), pickle.loads(pickle.dumps(env))]
    for actions in plan[10:]:
        if not env.agents:
            break
        for e in (env, *twins):
            e.step({a: actions[a] for a in e.agents})
        for twin in twins:
            np.testing.assert_array_equal(twin.state(), env.state())


def test_a_finished_robot_is_given_stop_commands_and_halts_after_the_delay():
    env = teamgym.make("Navigation-v0", actuation_delay=0.2, true_delay="fixed", n_robots=2, n_obstacles=0)
    env.reset(seed=1)
    env.live_agents = env.live_agents[:1]  # robot 1 left the episode: its queue fills with (0, 0)
    robot = env.robot_list[1]
    robot.given_commands = ((0.3, 0.0), (0.3, 0.0))
    moved = []
    for _ in range(3):
        before = np.array(robot.pose[:2])
        env._delay_actuation(env.robot_list, env.np_random)
        env.world.step()
        moved.append(float(np.hypot(*(np.array(robot.pose[:2]) - before))))
    assert robot.given_commands[-2:] == ((0.0, 0.0), (0.0, 0.0))
    assert moved[0] > 0.02 and moved[1] > 0.02  # the two commands in flight still run
    assert moved[2] < 0.25 * moved[1]  # then (0, 0): the robot brakes to a halt
