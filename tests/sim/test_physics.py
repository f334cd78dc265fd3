"""Physical invariants of the simulator and of Navigation-v0 episodes.

Overlaps are measured in every physics substep by the ``penetration_probe`` fixture
(a post-solve collision callback, see conftest.py), not only at control-step boundaries.
"""

import math

import numpy as np
import pytest

import teamgym
from teamgym.sim import Box, Category, DiffDriveRobot, RobotSpec, Wall, World
from teamgym.sim.objects import GRAVITY

MAX_OVERLAP = 2e-3
ENV_SPEC = RobotSpec(max_wheel_speed=0.4)  # Navigation-v0's default wheel speed limit


# -- walls ---------------------------------------------------------------------------


def drive_into_wall(spec, angle_deg, offset, probe_cls, seconds=10.0):
    """Drive at full wheel speed towards a wall at x = 0.8 (the robot's rim starts ``offset`` from it)."""
    world = World((1.0, 1.0))
    world.add(Wall("wall", (0.8, -5.0), (0.8, 6.0), 0.02))  # long enough to slide along for 10 s
    robot = world.add(DiffDriveRobot("r", (0.79 - spec.radius - offset, 0.5), math.radians(angle_deg), spec))
    probe = probe_cls(world.space)
    worst_after_step = -1.0
    for _ in range(round(seconds / world.dt)):
        robot.set_wheel_speeds(spec.max_wheel_speed, spec.max_wheel_speed)
        world.step()
        worst_after_step = max(worst_after_step, robot.pose[0] + spec.radius - 0.79)
    assert probe.calls > 0, "the robot never touched the wall"
    return max(probe.deepest(Category.ROBOT, Category.WALL), worst_after_step)


@pytest.mark.parametrize("angle_deg", [0, 30, 60, -45, 80])
@pytest.mark.parametrize("offset", [0.0, 0.003, 0.0117, 0.05])
def test_full_speed_robot_never_penetrates_wall(angle_deg, offset, penetration_probe):
    assert drive_into_wall(ENV_SPEC, angle_deg, offset, penetration_probe) < MAX_OVERLAP


def test_default_spec_never_penetrates_wall(penetration_probe):
    worst = max(
        drive_into_wall(RobotSpec(), angle, offset, penetration_probe)
        for angle in (0, 30, 60, -45)
        for offset in (0.0, 0.003, 0.0117, 0.05)
    )
    assert worst < MAX_OVERLAP


@pytest.mark.parametrize("seed", [0, 1])
def test_navigation_robots_driven_into_arena_walls(seed, penetration_probe):
    env = teamgym.make("Navigation-v0", n_robots=6, n_obstacles=0, max_cycles=100)
    env.reset(seed=seed)
    probe = penetration_probe(env.world.space)
    full = np.array([env.config.max_wheel_speed, 0.0], dtype=np.float32)
    while env.agents:
        env.step({a: full for a in env.agents})
    size, r = env.config.arena_size, env.config.robot_radius
    gaps = [min(x - r, y - r, size - x - r, size - y - r) for x, y, _ in (rb.pose for rb in env.robots.values())]
    assert max(gaps) < 0.01, "every robot should end up pressed against a boundary wall"
    assert min(gaps) > -MAX_OVERLAP
    assert 0 < probe.deepest(Category.ROBOT, Category.WALL) < MAX_OVERLAP


# -- boxes -----------------------------------------------------------------------------


def push_box(mass, n_robots=1, seconds=3.0, probe_cls=None):
    """Robots start 5 mm behind a 10 cm box (mu = 0.5) and push it in +x at 0.2 m/s."""
    world = World((3.0, 3.0))
    box = world.add(Box("box", (0.1, 0.1), (1.0, 1.0), mass, ground_friction=0.5))
    spec = RobotSpec()
    ys = [1.0] if n_robots == 1 else [1.0 - 0.03, 1.0 + 0.03]
    robots = [world.add(DiffDriveRobot(f"r{i}", (0.95 - spec.radius - 0.005, y), 0.0, spec)) for i, y in enumerate(ys)]
    probe = probe_cls(world.space) if probe_cls else None
    start = np.array(box.position)
    for _ in range(round(seconds / world.dt)):
        for robot in robots:
            robot.set_command(0.2, 0.0)
        world.step()
    moved = float(np.hypot(*(np.array(box.position) - start)))
    return moved, robots, probe


def test_robot_pushes_light_box():
    spec = RobotSpec()
    mass = 0.06
    assert 0.5 * mass * GRAVITY < spec.max_motor_force
    moved, robots, _ = push_box(mass)
    assert moved > 0.10
    assert robots[0].encoders.slip < 0.01


def test_robot_cannot_push_box_three_times_too_heavy(penetration_probe):
    spec = RobotSpec()
    mass = 3 * spec.max_motor_force / (0.5 * GRAVITY)
    moved, robots, probe = push_box(mass, probe_cls=penetration_probe)
    assert moved < 0.01
    assert robots[0].pose[0] < 1.0  # still behind the box
    assert probe.deepest(Category.ROBOT, Category.BOX) < MAX_OVERLAP


def test_two_robots_move_box_one_cannot():
    spec = RobotSpec()
    mass = 0.15  # friction 0.74 N: more than one robot's 0.6 N, less than two robots' 1.2 N
    assert spec.max_motor_force < 0.5 * mass * GRAVITY < 2 * spec.max_motor_force
    alone, _, _ = push_box(mass, n_robots=1)
    together, _, _ = push_box(mass, n_robots=2)
    assert alone < 0.01
    assert together > 0.10


# -- encoders ----------------------------------------------------------------------------


def test_encoders_stall_against_immovable_box():
    _, robots, _ = push_box(100.0, seconds=2.0)
    enc = robots[0].encoders
    commanded = 0.2 * 0.1 / robots[0].spec.wheel_radius
    assert enc.commanded_left == pytest.approx(commanded) and enc.commanded_right == pytest.approx(commanded)
    assert abs(enc.actual_left) < 0.01 * commanded and abs(enc.actual_right) < 0.01 * commanded
    assert enc.slip > 0.99


def test_encoders_free_driving_have_no_slip():
    world = World((3.0, 3.0))
    robot = world.add(DiffDriveRobot("r", (1.5, 1.5), 0.0))
    for _ in range(5):
        robot.set_command(0.2, 1.5)
        world.step()
    enc = robot.encoders
    assert enc.slip < 0.01
    left, right = (0.2 - 0.5 * robot.spec.wheel_base * 1.5), (0.2 + 0.5 * robot.spec.wheel_base * 1.5)
    r = robot.spec.wheel_radius
    assert enc.actual_left == pytest.approx(left * 0.1 / r, rel=0.01)
    assert enc.actual_right == pytest.approx(right * 0.1 / r, rel=0.01)
    assert robot.odometer == pytest.approx(0.2 * 0.5, rel=0.05)


# -- actuation delay ------------------------------------------------------------------


def heading_change_after_switch(delay):
    world = World((3.0, 3.0))
    robot = world.add(DiffDriveRobot("r", (1.5, 1.5), 0.0))
    robot.actuation_delay = delay
    for _ in range(3):
        robot.set_command(0.2, 0.0)
        world.step()
    before = robot.pose[2]
    robot.set_command(0.2, 3.0)
    world.step()
    turned_first = robot.pose[2] - before
    world.step()  # the command is unchanged now: no delay phase
    return turned_first, robot.pose[2] - before - turned_first


def test_actuation_delay_keeps_previous_command_first():
    plain_first, plain_second = heading_change_after_switch(0.0)
    late_first, late_second = heading_change_after_switch(0.04)
    assert plain_first == pytest.approx(3.0 * 0.1, abs=0.02)
    # With a 40 ms delay the robot drives straight for 40 ms, then turns for 60 ms.
    assert late_first == pytest.approx(3.0 * 0.06, abs=0.02)
    assert plain_first - late_first == pytest.approx(3.0 * 0.04, abs=0.005)
    assert late_second == pytest.approx(plain_second, abs=1e-6) == pytest.approx(0.3, abs=0.005)


def test_navigation_actuation_delay_lags_a_command_change():
    kwargs = dict(n_robots=4, n_obstacles=0, max_cycles=10)
    plain = teamgym.make("Navigation-v0", **kwargs)
    late = teamgym.make("Navigation-v0", actuation_delay=0.1, **kwargs)
    plain.reset(seed=5)
    late.reset(seed=5)
    np.testing.assert_array_equal(plain.state(), late.state())
    still = {a: np.zeros(2, dtype=np.float32) for a in plain.agents}
    go = {a: np.array([0.4, 0.0], dtype=np.float32) for a in plain.agents}

    def displacement(env, actions):
        before = np.array([r.pose[:2] for r in env.robots.values()])
        env.step(actions)
        return np.hypot(*(np.array([r.pose[:2] for r in env.robots.values()]) - before).T)

    np.testing.assert_array_equal(displacement(plain, still), displacement(late, still))
    moved_plain = displacement(plain, go)
    moved_late = displacement(late, go)
    assert np.all(moved_plain > 0.02)
    # The delay (50-100 ms of a 100 ms step) keeps the old "stand still" command first.
    assert np.all(moved_late < 0.5 * moved_plain)
    moved_late_next = displacement(late, go)
    assert np.all(moved_late_next > moved_late + 0.01)


def heading_steps(delay, commands, lag=True):
    """Heading change of each control step of a robot given ``commands`` (v, ω), one per step, ``delay`` s late."""
    world = World((3.0, 3.0))
    robot = world.add(DiffDriveRobot("r", (1.5, 1.5), 0.0))
    turns = []
    for command in commands:
        robot.set_command(*command)
        if lag:
            robot.lag_commands(robot.command, delay, world.dt, depth=5)
        else:
            robot.actuation_delay = delay
        before = robot.body.angle
        world.step()
        turns.append(robot.body.angle - before)
    return np.array(turns)


#: Steer left, right, straight, left again: each command's turn shows which step runs it.
TURNS = [(0.2, 0.0), (0.2, 3.0), (0.2, 0.0), (0.2, -2.0), (0.2, -2.0), (0.2, 0.0), (0.2, 1.0), (0.2, 0.0), (0.2, 0.0), (0.2, 0.0)]


@pytest.mark.parametrize("steps", [1, 2, 3])
def test_a_delay_of_whole_steps_runs_the_command_given_that_many_steps_earlier(steps):
    """Section 6.1 past Δt (command queue): with delay m·Δt step n runs the command of step n − m, whole."""
    plain = heading_steps(0.0, TURNS)
    late = heading_steps(steps * 0.1, TURNS)
    np.testing.assert_allclose(late[:steps], 0.0, atol=1e-9)  # before the first command: (0, 0)
    np.testing.assert_allclose(late[steps:], plain[:-steps], atol=0.005)
    assert plain[1] > 0.25  # 3 rad/s for 0.1 s (a little less: the motors take up the turn)


def test_a_delay_between_steps_splits_each_step_between_two_earlier_commands():
    """Delay 1.5Δt = Δt + r: step n runs the command of step n − 2 for r = 0.05 s, then that of n − 1."""
    omega = np.array([w for _, w in TURNS])
    expected = 0.05 * (np.r_[0.0, omega[:-1]] + np.r_[0.0, 0.0, omega[:-2]])
    late = heading_steps(0.15, TURNS)
    # Within 0.02 rad (the motors take up a turn a little late); the one- and two-step models miss by 0.15.
    np.testing.assert_allclose(late, expected, atol=0.02)
    assert late[2] == pytest.approx(0.15, abs=0.02) == late[3]


@pytest.mark.parametrize("delay", [0.0, 0.04, 0.1])
def test_the_command_queue_below_one_step_is_the_one_step_model(delay):
    np.testing.assert_array_equal(heading_steps(delay, TURNS, lag=True), heading_steps(delay, TURNS, lag=False))


def test_lag_commands_refuses_a_queue_too_short_for_the_delay():
    robot = DiffDriveRobot("r", (1.0, 1.0), 0.0)
    with pytest.raises(ValueError, match="depth >= 4"):
        robot.lag_commands((0.1, 0.0), 0.25, 0.1, depth=3)
    assert robot.given_commands == () and robot.command == (0.0, 0.0)


def test_navigation_delay_of_two_steps_moves_robots_two_steps_late():
    kwargs = dict(n_robots=3, n_obstacles=0, max_cycles=10)
    plain = teamgym.make("Navigation-v0", **kwargs)
    late = teamgym.make("Navigation-v0", actuation_delay=0.2, true_delay="fixed", **kwargs)
    plain.reset(seed=3)
    late.reset(seed=3)
    go = {a: np.array([0.3, 1.0], dtype=np.float32) for a in plain.agents}

    def positions(env, steps):
        out = []
        for _ in range(steps):
            env.step(go)
            out.append(np.array([r.pose for r in env.robots.values()]))
        return np.array(out)

    start = np.array([r.pose for r in late.robots.values()])
    moved_plain, moved_late = positions(plain, 2), positions(late, 4)
    np.testing.assert_allclose(moved_late[:2], np.broadcast_to(start, moved_late[:2].shape), atol=1e-9)
    np.testing.assert_allclose(moved_late[2:], moved_plain, atol=1e-6)
    assert np.all(np.hypot(*(moved_plain[0, :, :2] - start[:, :2]).T) > 0.02)


# -- crowded episodes ------------------------------------------------------------------


def test_crowded_navigation_robots_never_overlap(penetration_probe, random_policy):
    env = teamgym.make("Navigation-v0", n_robots=16, arena_size=1.2, n_obstacles=2, min_goal_distance=0.3, max_cycles=150)
    env.reset(seed=2)
    probe = penetration_probe(env.world.space)
    rng = np.random.default_rng(2)
    r = env.config.robot_radius
    worst = -1.0
    while env.agents:
        env.step(random_policy(env, rng))
        p = np.array([rb.pose[:2] for rb in env.robots.values()])
        d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
        np.fill_diagonal(d, np.inf)
        worst = max(worst, 2 * r - d.min())
    assert Category.ROBOT in {k for key in probe.worst for k in key}
    assert frozenset({Category.ROBOT}) in probe.worst, "no robot-robot contact happened; crowd the arena more"
    assert probe.deepest(Category.ROBOT, Category.ROBOT) < MAX_OVERLAP
    assert worst < MAX_OVERLAP
    assert probe.deepest(Category.ROBOT, Category.WALL) < MAX_OVERLAP


def test_moving_obstacles_stay_inside_arena(penetration_probe, random_policy):
    env = teamgym.make("Navigation-v0", n_robots=3, n_obstacles=8, arena_size=1.0, obstacle_speed=0.4, max_cycles=150)
    env.reset(seed=4)
    probe = penetration_probe(env.world.space, Category.OBSTACLE)
    size = env.config.arena_size
    rng = np.random.default_rng(4)
    start = np.array([o.position for o in env.obstacles])
    lowest, highest = np.inf, -np.inf
    while env.agents:
        env.step(random_policy(env, rng))
        for obstacle in env.obstacles:
            verts = np.array([obstacle.body.local_to_world(v) for v in obstacle.local_vertices])
            lowest, highest = min(lowest, verts.min()), max(highest, verts.max())
    assert lowest > -MAX_OVERLAP and highest < size + MAX_OVERLAP
    assert probe.deepest(Category.OBSTACLE, Category.WALL) < MAX_OVERLAP
    # They did move (and so had to bounce off the walls within 15 s at 0.4 m/s in a 1 m arena).
    end = np.array([o.position for o in env.obstacles])
    assert np.all(np.hypot(*(end - start).T) > 0.0) and lowest < 0.05 and highest > size - 0.05
