"""Differential-drive kinematics (paper 001 eq. 6), saturation and arc following."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from teamgym.sim import DiffDriveRobot, RobotSpec, World, body_command, saturate, wheel_speeds, wrap_angle

finite = st.floats(min_value=-50.0, max_value=50.0, allow_nan=False)
bases = st.floats(min_value=0.01, max_value=0.5)


@settings(max_examples=200, deadline=None, database=None)
@given(v=finite, omega=finite, base=bases)
def test_wheel_speeds_match_eq6_ccw_form(v, omega, base):
    v_left, v_right = wheel_speeds(v, omega, base)
    # Counter-clockwise form of eq. (6): v_L = v - (L/2) w, v_R = v + (L/2) w.
    assert v_left == pytest.approx(v - base / 2 * omega, abs=1e-12)
    assert v_right == pytest.approx(v + base / 2 * omega, abs=1e-12)


@settings(max_examples=200, deadline=None, database=None)
@given(v=finite, omega=finite, base=bases)
def test_body_command_inverts_wheel_speeds(v, omega, base):
    v2, omega2 = body_command(*wheel_speeds(v, omega, base), base)
    assert v2 == pytest.approx(v, abs=1e-9)
    assert omega2 == pytest.approx(omega, abs=1e-7)


@settings(max_examples=200, deadline=None, database=None)
@given(v_left=finite, v_right=finite, base=bases)
def test_wheel_speeds_invert_body_command(v_left, v_right, base):
    vl2, vr2 = wheel_speeds(*body_command(v_left, v_right, base), base)
    assert vl2 == pytest.approx(v_left, abs=1e-9)
    assert vr2 == pytest.approx(v_right, abs=1e-9)


def test_faster_right_wheel_turns_left():
    """Positive omega (right wheel faster) is a counter-clockwise turn."""
    v, omega = body_command(0.1, 0.3, 0.05)
    assert v == pytest.approx(0.2)
    assert omega == pytest.approx(4.0)
    world = World((2.0, 2.0))
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), 0.0))
    robot.set_wheel_speeds(0.1, 0.3)
    for _ in range(3):
        world.step()
    x, y, theta = robot.pose
    assert theta > 0.3  # turned left (CCW)
    assert y > 1.0  # and curved towards +y


@settings(max_examples=300, deadline=None, database=None)
@given(v=finite, omega=finite)
def test_saturate_keeps_curvature_and_wheel_limits(v, omega):
    spec = RobotSpec()
    vs, ws = saturate(v, omega, spec)
    left, right = wheel_speeds(vs, ws, spec.wheel_base)
    assert max(abs(left), abs(right)) <= spec.max_wheel_speed * (1 + 1e-9)
    # Same direction of travel on the same arc: (vs, ws) = k (v, omega) with 0 < k <= 1.
    assert vs * omega == pytest.approx(ws * v, abs=1e-9)
    assert vs * v >= 0 and ws * omega >= 0
    assert abs(vs) <= abs(v) + 1e-12 and abs(ws) <= abs(omega) + 1e-12
    l0, r0 = wheel_speeds(v, omega, spec.wheel_base)
    if max(abs(l0), abs(r0)) <= spec.max_wheel_speed:
        assert (vs, ws) == (v, omega)
    else:
        # Saturated commands use the full wheel speed on the faster wheel.
        assert max(abs(left), abs(right)) == pytest.approx(spec.max_wheel_speed)


def test_set_command_saturates_and_rejects_non_finite():
    robot = DiffDriveRobot("r", (0.0, 0.0))
    robot.set_command(10.0, 0.0)
    assert robot.command == pytest.approx((robot.spec.max_wheel_speed, 0.0))
    for bad in [(math.nan, 0.0), (0.0, math.inf), (-math.inf, 1.0)]:
        with pytest.raises(ValueError, match="'r'"):
            robot.set_command(*bad)
    assert robot.command == pytest.approx((robot.spec.max_wheel_speed, 0.0))


@pytest.mark.parametrize(
    ("v", "omega", "theta0"),
    [(0.2, 1.0, 0.3), (0.1, -2.0, -1.0), (0.3, 0.5, 2.0), (-0.2, 1.0, 0.0), (0.05, 4.0, -2.5)],
)
def test_constant_command_follows_arc(v, omega, theta0):
    """A robot commanded (v, w) for 1 s stays on the circle of radius v/w about the ICC."""
    world = World((4.0, 4.0), dt=0.1)
    start = np.array([2.0, 2.0])
    robot = world.add(DiffDriveRobot("r", tuple(start), theta0))
    robot.set_command(v, omega)
    assert robot.command == (v, omega)  # within the wheel limits, not saturated
    radius = v / omega
    centre = start + radius * np.array([-math.sin(theta0), math.cos(theta0)])
    for _ in range(10):
        world.step()
        x, y, _ = robot.pose
        assert abs(np.hypot(x - centre[0], y - centre[1]) - abs(radius)) < 3e-3
    # The heading turned by w t (less a short spin-up lag from rest).
    assert wrap_angle(robot.pose[2] - (theta0 + omega * 1.0)) == pytest.approx(0.0, abs=0.04)
    expected = centre + radius * np.array([math.sin(theta0 + omega), -math.cos(theta0 + omega)])
    # Along the arc the robot lags a little behind the ideal (it starts from rest).
    assert np.hypot(*(np.array(robot.pose[:2]) - expected)) < 0.01


def test_straight_command_keeps_line():
    world = World((4.0, 4.0))
    theta0 = 0.7
    robot = world.add(DiffDriveRobot("r", (1.0, 1.0), theta0))
    robot.set_command(0.4, 0.0)
    for _ in range(10):
        world.step()
    x, y, theta = robot.pose
    d = np.array([x - 1.0, y - 1.0])
    across = -d[0] * math.sin(theta0) + d[1] * math.cos(theta0)
    along = d[0] * math.cos(theta0) + d[1] * math.sin(theta0)
    assert abs(across) < 1e-6
    assert theta == pytest.approx(theta0, abs=1e-6)
    # 0.4 m/s for 1 s, less the short acceleration from rest (force-limited motors).
    assert 0.37 < along <= 0.4 + 1e-9
    assert robot.velocity[0] == pytest.approx(0.4, abs=1e-3)


def test_wrap_angle_range():
    angles = np.linspace(-20, 20, 2001)
    wrapped = wrap_angle(angles)
    assert np.all(wrapped > -np.pi) and np.all(wrapped <= np.pi + 1e-12)
    assert np.allclose(np.cos(wrapped), np.cos(angles)) and np.allclose(np.sin(wrapped), np.sin(angles))
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)


@pytest.mark.parametrize(
    "field",
    ["radius", "wheel_base", "wheel_radius", "max_wheel_speed", "mass", "max_motor_force"],
)
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_robot_spec_rejects_bad_values(field, value):
    with pytest.raises(ValueError, match=field):
        RobotSpec(**{field: value})


@settings(max_examples=100, deadline=None, database=None)
@given(rows=st.lists(st.tuples(finite, finite, bases, st.floats(min_value=0.01, max_value=2.0), st.booleans()), max_size=6))
def test_set_commands_is_set_command_robot_by_robot(rows):
    """The batch form of ``set_command`` (one numpy pass) gives each robot the same command, bit for bit."""
    from teamgym.sim.robot import set_commands

    def robots() -> list[DiffDriveRobot]:
        made = []
        for i, (_, _, base, top, enabled) in enumerate(rows):
            robot = DiffDriveRobot(f"r{i}", (0.0, 0.0), spec=RobotSpec(radius=0.3, wheel_base=base, max_wheel_speed=top))
            robot.enabled = enabled
            made.append(robot)
        return made

    one_by_one, together = robots(), robots()
    for robot, (v, omega, *_) in zip(one_by_one, rows):
        robot.set_command(v, omega)
    set_commands(together, np.array([(v, omega) for v, omega, *_ in rows]))
    assert [r.command for r in together] == [r.command for r in one_by_one]


def test_set_commands_rejects_a_row_that_is_not_finite_before_commanding_any():
    from teamgym.sim.robot import set_commands

    robots = [DiffDriveRobot(f"r{i}", (0.0, 0.0)) for i in range(2)]
    with pytest.raises(ValueError, match="robot 'r1': command must be finite"):
        set_commands(robots, np.array([[0.1, 0.0], [math.nan, 0.0]]))
    assert [r.command for r in robots] == [(0.0, 0.0), (0.0, 0.0)]
