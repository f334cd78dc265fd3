"""Behaviour-based controller (paper 000, section 2.2, eqs. 5-6) and the task-execution watcher (Fig. 4)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from teamgym.control.behaviour import (
    AVOID_FRONT,
    AVOID_LEFT,
    AVOID_RIGHT,
    BEHAVIOURS,
    GOAL_TRACKING,
    NARROW_PASSAGE,
    STOP,
    STROLL,
    BehaviourController,
    BehaviourParameters,
    sigmoid,
)
from teamgym.control.watcher import Task, TaskWatcher, WatcherState
from teamgym.maps import load_map
from teamgym.maps.build import build_world
from teamgym.sim import KHEPERA_RING, DiffDriveRobot, ProximityRing, World

FREE = np.full(8, 0.1)
ORIGIN = (0.0, 0.0, 0.0)


def rays(**near):
    """A ring reading with the given rays (by index name r0..r7) at the given distances."""
    d = FREE.copy()
    for key, value in near.items():
        d[int(key[1:])] = value
    return d


def test_sigmoid():
    assert sigmoid(0.0) == 0.5
    assert sigmoid(800.0) == 1.0 and sigmoid(-800.0) == 0.0
    assert sigmoid(2.0) + sigmoid(-2.0) == pytest.approx(1.0)


def test_activations_grow_as_objects_come_closer():
    ctl = BehaviourController()
    far = ctl.activations(ORIGIN, rays(r1=0.09, r4=0.09, r2=0.09), (1.0, 0.0))
    near = ctl.activations(ORIGIN, rays(r1=0.02, r4=0.02, r2=0.02), (1.0, 0.0))
    for k in (AVOID_LEFT, AVOID_RIGHT, AVOID_FRONT, NARROW_PASSAGE):
        assert near[k] > far[k]
    assert near[STROLL] < far[STROLL]
    # goal tracking fades and stop rises as the robot reaches its target
    a_far = ctl.activations(ORIGIN, FREE, (0.5, 0.0))
    a_at = ctl.activations(ORIGIN, FREE, (0.001, 0.0))
    assert a_far[GOAL_TRACKING] > 0.99 > a_at[GOAL_TRACKING]
    assert a_at[STOP] > a_far[STOP]
    assert all(0.0 <= a <= 1.0 for a in np.concatenate([far, near, a_far, a_at]))


@settings(max_examples=200, deadline=None)
@given(
    d=st.lists(st.floats(0.0, 0.1), min_size=8, max_size=8),
    tx=st.floats(-1, 1),
    ty=st.floats(-1, 1),
    theta=st.floats(-math.pi, math.pi),
    collided=st.booleans(),
)
def test_priority_arbitration_eq5_and_controls_eq6(d, tx, ty, theta, collided):
    params = BehaviourParameters()
    ctl = BehaviourController(params)
    pose = (0.0, 0.0, theta)
    out = ctl.step(pose, np.array(d), (tx, ty), collided=collided)
    weighted = out.activations * np.array(params.priorities)
    assert out.winner == int(np.argmax(weighted))  # eq. (5)
    np.testing.assert_allclose(out.weighted, weighted)
    v, omega = out.command
    assert abs(v) <= params.v_max + 1e-12 and abs(omega) <= params.omega_max + 1e-12
    if collided:
        assert out.winner_name == "stop" and out.command == (0.0, 0.0)
    # eq. (6): the controls depend on the winner's activation only through f_k
    again = BehaviourController(params)._control(out.winner, float(out.activations[out.winner]), pose, np.array(d), (tx, ty))
    assert again == pytest.approx(out.command)


@pytest.mark.parametrize(
    ("proximity", "target", "winner", "check"),
    [
        (FREE, (0.5, 0.0), GOAL_TRACKING, lambda v, w: v > 0.1 and abs(w) < 1e-9),
        (FREE, (0.0, 0.5), GOAL_TRACKING, lambda v, w: v < 1e-9 and w > 0),  # turn left on the spot
        (rays(r1=0.02), (0.5, 0.0), AVOID_LEFT, lambda v, w: w < 0),
        (rays(r4=0.02), (0.5, 0.0), AVOID_RIGHT, lambda v, w: w > 0),
        (rays(r2=0.01, r3=0.01, r5=0.03), (0.5, 0.0), AVOID_FRONT, lambda v, w: v <= 0 and w > 0),  # right side busier
        (rays(r0=0.02, r5=0.025, r1=0.05, r4=0.05), (0.5, 0.0), NARROW_PASSAGE, lambda v, w: v > 0 and w < 0),  # centre
        (FREE, (0.001, 0.0), STOP, lambda v, w: v == 0 and w == 0),
        (FREE, None, STOP, lambda v, w: v == 0 and w == 0),
    ],
)
def test_each_behaviour_wins_where_it_should(proximity, target, winner, check):
    out = BehaviourController().step(ORIGIN, proximity, target)
    assert out.winner_name == BEHAVIOURS[winner]
    assert check(*out.command), out.command


def test_stroll_without_target_and_avoid_front_keeps_turning_one_way():
    out = BehaviourController().step(ORIGIN, FREE, None, stroll=True)
    assert out.winner == STROLL and out.command[0] > 0 and out.command[1] == 0
    ctl = BehaviourController()
    first = ctl.step(ORIGIN, rays(r2=0.01, r3=0.01), (0.5, 0.0)).command[1]
    flipped = ctl.step(ORIGIN, rays(r2=0.01, r3=0.01, r0=0.02, r1=0.02), (0.5, 0.0)).command[1]
    assert np.sign(first) == np.sign(flipped)  # no dithering in front of a wall
    ctl.step(ORIGIN, FREE, (0.5, 0.0))
    assert ctl._turn == 0.0


@pytest.mark.parametrize(
    ("changes", "fragment"),
    [({"priorities": (1.0,) * 6}, "priorities"), ({"v_max": 0.0}, "v_max"), ({"steepness": math.inf}, "steepness")],
)
def test_bad_parameters(changes, fragment):
    with pytest.raises(ValueError, match=fragment):
        BehaviourParameters(**changes)


# -- the watcher (Fig. 4) -------------------------------------------------------------------


def goal_task(done_at=0.5, **kwargs):
    return Task("GoTo(x)", ((0.25, 0.0), (done_at, 0.0)), lambda x, y: x >= done_at, **kwargs)


def test_watcher_walks_through_its_four_states():
    watcher = TaskWatcher()
    assert watcher.state == WatcherState.WAITING and watcher.control(ORIGIN, FREE) == (0.0, 0.0)
    watcher.assign(goal_task(), time=1.0, position=(0.0, 0.0), odometer=2.0)
    assert watcher.state == WatcherState.EXECUTING and watcher.target == (0.25, 0.0)
    v, _ = watcher.control(ORIGIN, FREE)
    assert v > 0 and watcher.last_step.winner == GOAL_TRACKING
    watcher.control((0.24, 0.0, 0.0), FREE)
    assert watcher.target == (0.5, 0.0)  # the first waypoint is passed
    assert watcher.after_step(2.0, (0.3, 0.0), 2.3) == WatcherState.EXECUTING
    assert watcher.after_step(3.0, (0.5, 0.0), 2.6) == WatcherState.COMPLETED
    report = watcher.report
    assert (report.status, report.duration, report.straight, report.travelled) == (
        WatcherState.COMPLETED,
        2.0,
        pytest.approx(0.5),
        pytest.approx(0.6),
    )
    assert watcher.control(ORIGIN, FREE) == (0.0, 0.0)  # stopped, waiting for the coordinator
    watcher.acknowledge()
    assert watcher.state == WatcherState.WAITING


@pytest.mark.parametrize(
    ("kwargs", "steps", "reason"),
    [
        ({"stall_time": 2.0}, [(t, (0.0, 0.0), False) for t in np.arange(0.1, 3.0, 0.1)], "stalled"),
        ({"timeout": 1.0, "stall_time": 50.0}, [(t, (0.02 * t, 0.0), False) for t in np.arange(0.1, 1.5, 0.1)], "timeout"),
        ({"fail_on_collision": True}, [(0.1, (0.01, 0.0), True)], "collision"),
    ],
)
def test_watcher_exceptions(kwargs, steps, reason):
    watcher = TaskWatcher(**kwargs)
    watcher.assign(goal_task(), 0.0, (0.0, 0.0), 0.0)
    for t, p, hit in steps:
        state = watcher.after_step(float(t), p, 0.0, hit)
        if state != WatcherState.EXECUTING:
            break
    assert state == WatcherState.FAILED and watcher.report.reason == reason


def test_collisions_only_fail_when_asked_and_checks_report_their_reason():
    watcher = TaskWatcher()
    watcher.assign(goal_task(), 0.0, (0.0, 0.0), 0.0)
    assert watcher.after_step(0.1, (0.05, 0.0), 0.05, collided=True) == WatcherState.EXECUTING
    checked = TaskWatcher()
    checked.assign(goal_task(check=lambda x, y: "door closed" if x > 0.1 else None), 0.0, (0.0, 0.0), 0.0)
    assert checked.after_step(0.1, (0.05, 0.0), 0.05) == WatcherState.EXECUTING
    assert checked.after_step(0.2, (0.15, 0.0), 0.15) == WatcherState.FAILED
    assert checked.report.reason == "door closed"


def test_wait_never_completes_and_stops_the_robot():
    watcher = TaskWatcher(stall_time=0.5, timeout=1.0)
    watcher.assign(Task("Wait()", (), None), 0.0, (0.0, 0.0), 0.0)
    for t in range(1, 50):
        assert watcher.control(ORIGIN, FREE) == (0.0, 0.0)
        assert watcher.after_step(0.1 * t, (0.0, 0.0), 0.0) == WatcherState.EXECUTING
    assert watcher.target is None
    with pytest.raises(ValueError, match="stall_time"):
        TaskWatcher(stall_time=0.0)


# -- section 5.2: point-to-point run -------------------------------------------------------------


def point_to_point(steps=300):
    """Start (50, 650) mm, target (600, 350) mm in room S6 of the lab office (paper 000, sec. 5.2)."""
    office = load_map("lab7")
    world = World(office.size)
    build_world(office, world)
    robot = world.add(DiffDriveRobot("robot", (0.05, 0.65), 0.0))
    ring = ProximityRing(KHEPERA_RING, 0.1)
    ctl = BehaviourController(record=True)
    target = (0.6, 0.35)
    contacts = 0
    for _ in range(steps):
        out = ctl.step(robot.pose, ring.read(robot, world.space), target)
        robot.set_command(*out.command)
        world.step()
        contacts += len(world.contacts_of("robot"))
        if out.winner == STOP:
            break
    activations, winners, commands = ctl.activation_history()
    assert activations.shape == (len(ctl.history), 7) and commands.shape == (len(ctl.history), 2)
    return robot, winners.tolist(), contacts


def test_point_to_point_reaches_the_target_without_collision():
    robot, winners, contacts = point_to_point()
    assert math.dist(robot.position, (0.6, 0.35)) < 0.025
    assert contacts == 0
    straight = math.dist((0.05, 0.65), (0.6, 0.35))
    assert robot.odometer > straight + 0.02  # it went around the desk in the way
    assert {GOAL_TRACKING, STOP} <= set(winners) and len(set(winners)) >= 3


@settings(max_examples=300, deadline=None)
@given(angle=st.floats(allow_nan=True, allow_infinity=True))
def test_scalar_wrap_is_wrap_angle_bit_for_bit(angle):
    from teamgym.control.behaviour import _wrap
    from teamgym.sim.robot import wrap_angle

    with np.errstate(invalid="ignore"):
        expected = np.float64(wrap_angle(angle))
    assert np.float64(_wrap(angle)).tobytes() == expected.tobytes() or (np.isnan(expected) and math.isnan(_wrap(angle)))


@settings(max_examples=300, deadline=None)
@given(values=st.lists(st.sampled_from([0.0, 0.3, 0.3, 1.0, -1.0, math.nan, math.inf]) | st.floats(), min_size=1, max_size=9))
def test_first_max_is_argmax(values):
    from teamgym.control.behaviour import _first_max

    assert _first_max(values) == int(np.argmax(np.array(values)))


def test_step_record_gives_arrays_of_its_levels():
    out = BehaviourController().step(ORIGIN, np.array([0.02, 0.05, 0.1, 0.1, 0.03, 0.01, 0.1, 0.1], np.float32), (0.4, 0.1))
    assert isinstance(out.activations, np.ndarray) and out.activations.tolist() == out.levels
    assert out.weighted.tolist() == [a * q for a, q in zip(out.levels, BehaviourParameters().priorities)]
