"""The cffi fast paths of teamgym.sim.chipmunk agree with pymunk's public API."""

import pickle

import numpy as np
import pymunk
import pytest

from teamgym.sim.chipmunk import BodyReader, RayCaster, body_poses, set_kinematic_motion, set_pivot_anchor_a, space_step


def test_set_kinematic_motion_equals_public_setters():
    fast, slow = (pymunk.Body(body_type=pymunk.Body.KINEMATIC) for _ in range(2))
    set_kinematic_motion(fast, (0.3, -1.2), 0.7, (0.05, -0.4), 2.5)
    slow.position, slow.angle, slow.velocity, slow.angular_velocity = (0.3, -1.2), 0.7, (0.05, -0.4), 2.5
    assert fast.position == slow.position and fast.angle == slow.angle
    assert fast.velocity == slow.velocity and fast.angular_velocity == slow.angular_velocity


def test_set_pivot_anchor_a_equals_public_setter():
    a, b = pymunk.Body(body_type=pymunk.Body.KINEMATIC), pymunk.Body(1.0, 1.0)
    pivot = pymunk.PivotJoint(a, b, (0.0, 0.0), (0.0, 0.0))
    set_pivot_anchor_a(pivot, (0.25, -0.5))
    assert pivot.anchor_a == (0.25, -0.5) and pivot.anchor_b == (0.0, 0.0)


def moving_space():
    space = pymunk.Space()
    bodies = []
    for i in range(5):
        body = pymunk.Body(1.0, 0.1)
        body.position = (0.3 * i, 0.1 * i)
        body.velocity = (0.1 * i, -0.2)
        body.angular_velocity = 0.3 - 0.1 * i
        space.add(body, pymunk.Circle(body, 0.1))
        bodies.append(body)
    return space, bodies


def test_body_poses_equal_the_public_getters():
    space, bodies = moving_space()
    for _ in range(3):
        space.step(0.05)
    assert body_poses(bodies[::-1]) == [(*body.position, body.angle) for body in bodies[::-1]]
    assert body_poses([]) == []


def test_body_reader_rows_follow_the_given_order():
    space, bodies = moving_space()
    space.step(0.01)
    chosen = [bodies[3], bodies[0], bodies[4]]
    reader = BodyReader(chosen)
    rows = reader.read(space)
    expected = [(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in chosen]
    np.testing.assert_array_equal(rows, np.array(expected))
    space.step(0.01)
    expected = [(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in chosen]
    np.testing.assert_array_equal(reader.read(space), np.array(expected))


def test_body_reader_refuses_bodies_outside_the_space():
    space, _ = moving_space()
    with pytest.raises(KeyError):
        BodyReader([pymunk.Body(1.0, 1.0)]).read(space)


def test_body_reader_survives_pickling_with_its_space():
    space, bodies = moving_space()
    reader = BodyReader(bodies[1:3])
    reader.read(space)
    space2, reader2 = pickle.loads(pickle.dumps((space, reader)))
    np.testing.assert_array_equal(reader2.read(space2), reader.read(space))


def test_raw_space_step_equals_public_step():
    (fast, fast_bodies), (slow, slow_bodies) = moving_space(), moving_space()
    fast.step(0.005)
    slow.step(0.005)
    for _ in range(9):
        space_step(fast._space, 0.005)
        slow.step(0.005)
    for a, b in zip(fast_bodies, slow_bodies):
        assert a.position == b.position and a.angle == b.angle and a.velocity == b.velocity


def test_ray_caster_equals_public_queries():
    space, _ = moving_space()
    caster = RayCaster()
    every = pymunk.ShapeFilter()
    rng = np.random.default_rng(0)
    for _ in range(200):
        start, end = tuple(rng.uniform(-0.5, 1.5, 2)), tuple(rng.uniform(-0.5, 1.5, 2))
        hit = space.segment_query_first(start, end, 0.0, every)
        alpha = caster.cast(space, start, end, every)
        assert (alpha is None) == (hit is None)
        if hit is not None:
            assert alpha == hit.alpha
        near = space.point_query_nearest(start, 0.05, every)
        assert caster.anything_within(space, start, 0.05, every) == (near is not None)
