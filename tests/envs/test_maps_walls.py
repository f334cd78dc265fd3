"""JoinedWalls (teamgym/maps/walls.py): many walls as one static entity give the world of the walls added one by one."""

import numpy as np
import pytest

from baselines.episode import static_geometry
from teamgym.maps import load_map
from teamgym.maps.build import map_entities
from teamgym.maps.walls import JoinedWalls
from teamgym.sim import DiffDriveRobot, Door, World
from teamgym.sim.objects import Wall

SEGMENTS = [
    ((0.2, 0.2), (1.8, 0.2)),
    ((1.8, 0.2), (1.8, 1.8)),
    ((1.8, 1.8), (0.2, 1.8)),
    ((0.2, 1.8), (0.2, 0.2)),
    ((1.0, 0.6), (1.0, 1.4)),
]


def walls():
    return [Wall(f"wall_{k}", a, b, 0.01) for k, (a, b) in enumerate(SEGMENTS)]


def rollout(joined: bool, steps: int = 120) -> tuple[np.ndarray, list]:
    """Two robots driving into the walls and each other; their state rows after every step, and the contacts."""
    world = World((2.0, 2.0))
    world.add(JoinedWalls("walls", walls())) if joined else [world.add(w) for w in walls()]
    robots = [world.add(DiffDriveRobot("r0", (0.6, 1.0), 0.3)), world.add(DiffDriveRobot("r1", (1.4, 1.0), 2.8))]
    rows, contacts = [], []
    for t in range(steps):
        for k, robot in enumerate(robots):
            robot.set_command(0.15, 0.8 * np.sin(0.05 * t + k))
        world.step()
        rows.append(world.states.copy())
        contacts.append(sorted({c.a if c.b.startswith("wall") else c.b for c in world.contacts}))
    return np.array(rows), contacts


def test_joined_walls_step_like_separate_walls_bit_for_bit():
    separate, touched = rollout(joined=False)
    joined, touched_joined = rollout(joined=True)
    assert np.array_equal(separate, joined)
    assert touched == touched_joined and any(touched)  # the robots did hit walls


def test_joined_walls_keep_the_shapes_and_their_order():
    loose = walls()
    properties = [(s.a, s.b, s.radius, s.friction, s.elasticity, s.collision_type, s.filter) for w in loose for s in w.shapes]
    joined = JoinedWalls("walls", loose)
    assert [(s.a, s.b, s.radius, s.friction, s.elasticity, s.collision_type, s.filter) for s in joined.shapes] == properties
    assert all(s.body is joined.body and s.entity is joined for s in joined.shapes)
    assert joined.bodies == [joined.body] and all(w.shapes == [] and w.bodies == [] for w in loose)
    world = World((2.0, 2.0))
    world.add(joined)
    assert len(world.space.bodies) == 1 and len(world.space.shapes) == len(SEGMENTS)
    assert joined.position == pytest.approx((1.0, 1.0))


def test_joined_walls_refuse_bad_input_and_change_nothing():
    with pytest.raises(ValueError, match="at least one wall"):
        JoinedWalls("walls", [])
    loose = walls()
    with pytest.raises(TypeError, match="not doors"):
        JoinedWalls("walls", [*loose, Door("door", (0, 0), (1, 0))])
    assert all(len(w.shapes) == 1 and w.shapes[0].body is w.body for w in loose)  # untouched
    JoinedWalls("walls", loose)
    with pytest.raises(ValueError, match="already in a space or joined"):
        JoinedWalls("again", loose)
    placed = Wall("placed", (0, 0), (1, 0))
    World((2.0, 2.0)).add(placed)
    with pytest.raises(ValueError, match="placed"):
        JoinedWalls("walls", [placed])


def test_static_geometry_lists_every_joined_wall():
    world = World((2.0, 2.0))
    world.add(JoinedWalls("walls", walls()))
    segments, furniture = static_geometry(world)
    assert segments == SEGMENTS and furniture == []


def test_map_entities_join_walls_in_front_of_doors_and_furniture():
    office = load_map("office12")
    loose = map_entities(office)
    joined = map_entities(office, join_walls=True)
    n_walls = sum(type(e) is Wall for e in loose)
    assert isinstance(joined[0], JoinedWalls) and len(joined[0].shapes) == n_walls
    assert [e.name for e in joined[1:]] == [e.name for e in loose[n_walls:]]
    assert [(w.a, w.b) for w in joined[0].walls] == [(w.a, w.b) for w in loose[:n_walls]]
