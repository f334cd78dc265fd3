"""Physics of BoxPushing-v0: light and heavy boxes follow from mass and friction, pushing primitives.

The issue's bar: one robot pushing a heavy box for 20 s moves it less than 1 cm; two robots
pushing side by side move it more than 10 cm. Overlaps are measured every substep.
"""

import math

import numpy as np
import pytest

import teamgym
from teamgym.control.primitives import Primitive, PrimitiveExecutor, PrimitiveParams
from teamgym.envs.box_pushing.config import BoxPushingConfig
from teamgym.sim import KHEPERA_RING, Box, Category, DiffDriveRobot, ProximityRing, RobotSpec, World

MAX_OVERLAP = 2e-3
CONFIG = BoxPushingConfig()
SPEC = RobotSpec()


def env_with_box(heavy, n_robots, offsets, seconds, heading=0.0):
    """A BoxPushing env with one box at (0.5, 0.45) and robots right behind it, driven with push-straight."""
    env = teamgym.make(
        "BoxPushing-v0",
        n_robots=n_robots,
        n_light_boxes=0 if heavy else 1,
        n_heavy_boxes=1 if heavy else 0,
        max_cycles=round(seconds / 0.1) + 5,
        direction_change_jitter=0.0,
    )
    env.reset(seed=0)
    box = env.world[env.box_names()[0]]
    box.body.position = box.control.position = (0.5, 0.45)
    box.body.angle = box.control.angle = 0.0
    env.world.space.reindex_shapes_for_body(box.body)
    half = box.size[0] / 2
    for agent, dy in zip(env.agents, offsets):
        env.robots[agent].teleport((0.5 - half - SPEC.radius - 0.003, 0.45 + dy), heading)
    env.world.read_states()
    env._read_sensors(env.agents)
    return env, box


def push_for(env, steps, probe=None):
    start = np.array(env.world[env.box_names()[0]].position)
    for _ in range(steps):
        env.step({a: int(Primitive.PUSH_STRAIGHT) for a in env.agents})
    return float(np.hypot(*(np.array(env.world[env.box_names()[0]].position) - start)))


def test_one_robot_pushes_a_light_box(penetration_probe):
    env, box = env_with_box(heavy=False, n_robots=1, offsets=[0.0], seconds=3.0)
    probe = penetration_probe(env.world.space)
    moved = push_for(env, 30)
    assert moved > 0.15  # ~ push_speed × 3 s
    assert probe.deepest(Category.ROBOT, Category.BOX) < MAX_OVERLAP


@pytest.mark.parametrize("offset", [0.0, 0.06, -0.07])
def test_one_robot_cannot_move_a_heavy_box_in_20_s(offset, penetration_probe):
    env, box = env_with_box(heavy=True, n_robots=1, offsets=[offset], seconds=20.0)
    probe = penetration_probe(env.world.space)
    angle = box.body.angle
    robot = env.robots["robot_0"]
    start = np.array(box.position)
    stalled = 0
    for _ in range(200):  # 20 s of pushing; the robot keeps pushing straight (no behaviours here)
        env.step({"robot_0": int(Primitive.GO_AHEAD)})
        stalled += robot.encoders.slip > 0.9
    moved = float(np.hypot(*(np.array(box.position) - start)))
    assert moved < 0.01
    assert abs(box.body.angle - angle) < math.radians(2)  # not even turned at a corner
    assert stalled > 190  # the encoders show "no rotation" (AS-2)
    assert probe.deepest(Category.ROBOT, Category.BOX) < MAX_OVERLAP


def test_two_robots_side_by_side_move_a_heavy_box(penetration_probe):
    env, box = env_with_box(heavy=True, n_robots=2, offsets=[-0.035, 0.035], seconds=20.0)
    probe = penetration_probe(env.world.space)
    start = np.array(box.position)
    for _ in range(200):  # until the box reaches the goal wall, if it does within 20 s
        if not env.agents:
            break
        env.step({a: int(Primitive.GO_AHEAD) for a in env.agents})
    moved = float(np.hypot(*(np.array(box.position) - start)))
    assert moved > 0.10
    assert probe.deepest(Category.ROBOT, Category.BOX) < MAX_OVERLAP
    assert probe.deepest(Category.ROBOT, Category.ROBOT) < MAX_OVERLAP


def test_a_line_of_two_robots_moves_a_heavy_box():
    """Serial pushing: the second robot pushes the first, whose motors add to it."""
    env, box = env_with_box(heavy=True, n_robots=2, offsets=[0.0, 0.0], seconds=10.0)
    first = env.robots["robot_0"].pose
    env.robots["robot_1"].teleport((first[0] - 2 * SPEC.radius - 0.003, first[1]), 0.0)
    start = box.position[0]
    for _ in range(100):
        if not env.agents:
            break
        env.step({a: int(Primitive.GO_AHEAD) for a in env.agents})
    assert box.position[0] - start > 0.10


def test_heavy_friction_sits_between_one_and_two_motors():
    for mass, size, ok in ((CONFIG.heavy_box_mass, CONFIG.heavy_box_size, True), (0.1, 0.16, False), (0.3, 0.16, False)):
        friction = CONFIG.box_friction * mass * 9.81
        assert (SPEC.max_motor_force < friction < 2 * SPEC.max_motor_force) == ok
        if not ok:
            with pytest.raises(teamgym.ConfigError, match="heavy_box_mass"):
                teamgym.make("BoxPushing-v0", heavy_box_mass=mass, heavy_box_size=size)


# -- pushing primitives -------------------------------------------------------------------


def push_with(primitive, seconds=6.0, box_angle=0.0):
    """Drive a bare robot behind a light box with one pushing primitive; return box displacement and rotation."""
    world = World((3.0, 3.0))
    box = world.add(Box("box", (CONFIG.light_box_size,) * 2, (1.0, 1.0), CONFIG.light_box_mass, CONFIG.box_friction, box_angle))
    robot = world.add(DiffDriveRobot("r", (1.0 - CONFIG.light_box_size / 2 - SPEC.radius - 0.003, 1.0), 0.0, SPEC))
    ring = ProximityRing(KHEPERA_RING, CONFIG.sensor_range)
    executor = PrimitiveExecutor(PrimitiveParams(ray_angles=tuple(KHEPERA_RING.tolist())))
    contact = 0
    for _ in range(round(seconds / world.dt)):
        proximity = ring.read(robot, world.space)
        contact += proximity[1:5].min() < 0.02
        executor.observe(proximity, (0.0, 0.0, 0.0, 0.0))
        robot.set_command(*executor.command(int(primitive)))
        world.step()
    moved = np.array(box.position) - (1.0, 1.0)
    return moved, box.body.angle - box_angle, robot.pose[2], contact / round(seconds / world.dt)


@pytest.mark.parametrize("box_angle", [0.0, 0.35, -0.35])
def test_push_straight_keeps_the_box_ahead(box_angle):
    moved, _, _, contact = push_with(Primitive.PUSH_STRAIGHT, box_angle=box_angle)
    assert contact > 0.95  # the box never slides off the round robot
    assert np.hypot(*moved) > 0.4


def test_push_clockwise_turns_the_box_to_the_left_and_counterclockwise_to_the_right():
    """Our reading of Fig. 5: the paper's rotation sense is clockwise-positive (see primitives.py)."""
    left, left_spin, left_heading, left_contact = push_with(Primitive.PUSH_CLOCKWISE)
    right, right_spin, right_heading, right_contact = push_with(Primitive.PUSH_COUNTERCLOCKWISE)
    assert left_contact > 0.95 and right_contact > 0.95
    assert left[1] > 0.02 and left_spin > math.radians(20) and left_heading > math.radians(20)
    assert right[1] < -0.02 and right_spin < -math.radians(20) and right_heading < -math.radians(20)
