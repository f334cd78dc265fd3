"""Snapshots of live simulation state: numpy views, external references, Chipmunk's solver state, trails."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pymunk
import pytest

from teamgym.envs.trails import TrailArchive
from teamgym.sim import snapshot, solver_state
from teamgym.sim.objects import Wall
from teamgym.sim.robot import DiffDriveRobot
from teamgym.sim.solver_state import SolverSpace
from teamgym.sim.world import World


def test_numpy_views_stay_views_of_their_root():
    readings = np.zeros((3, 6), dtype=np.float32)
    state = {"readings": readings, "proximity": readings[:, :4], "light": readings[:, 4:], "frozen": readings[0]}
    state["frozen"].flags.writeable = False
    plain, kept = pickle.loads(pickle.dumps(state)), snapshot.loads(snapshot.dumps(state))
    plain["proximity"][1, 2] = 5.0
    assert plain["readings"][1, 2] == 0.0  # plain pickle: the view became a copy of its own
    kept["proximity"][1, 2] = 5.0
    kept["light"][2, 1] = 7.0
    assert kept["readings"][1, 2] == 5.0 and kept["readings"][2, 5] == 7.0
    assert not kept["frozen"].flags.writeable and kept["readings"].flags.writeable


class Thing:
    """An object of a class of its own (externals are such objects: built-in containers are always pickled)."""


def test_external_objects_are_referred_to_and_resolved_on_load():
    owner, other = Thing(), Thing()
    data = snapshot.dumps({"me": owner, "list": [other], "again": other}, external=[owner, other])
    a, b = Thing(), Thing()
    loaded = snapshot.loads(data, external=[a, b])
    assert loaded["me"] is a and loaded["list"][0] is b and loaded["again"] is b
    with pytest.raises(pickle.UnpicklingError, match="external object 1.*given 1"):
        snapshot.loads(data, external=[a])


@dataclasses.dataclass(frozen=True)
class Frozen:
    a: int
    b: tuple


class Trimmed:
    """Pickles its own ``__getstate__`` (without the cache) and has no ``__setstate__``."""

    def __init__(self) -> None:
        self.kept, self.cache = [1, 2], "rebuilt"

    def __getstate__(self) -> dict:
        return {"kept": self.kept, "cache": None}


def test_objects_pickled_by_their_attributes_come_back_with_the_same_ones():
    """Such objects get their attributes set one by one (not written into their ``__dict__``, see the module docstring)."""
    frozen, trimmed = Frozen(1, (2.5, "x")), Trimmed()
    again_frozen, again_trimmed = snapshot.loads(snapshot.dumps([frozen, trimmed]))
    assert again_frozen == frozen and type(again_frozen) is Frozen
    assert (again_trimmed.kept, again_trimmed.cache) == ([1, 2], None)
    with pytest.raises(dataclasses.FrozenInstanceError):
        again_frozen.a = 3


def test_the_struct_layouts_match_the_linked_chipmunk():
    assert solver_state.layout_matches()


def driven_space() -> tuple[SolverSpace, list[pymunk.Constraint]]:
    """A body held to a moving kinematic body by force-limited pivot and gear joints (the robots' drive), stepped."""
    space = SolverSpace()
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.velocity, control.angular_velocity = (0.4, 0.1), 1.5
    body = pymunk.Body(0.08, 3e-5)
    joints = [pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0)), pymunk.GearJoint(control, body, 0.0, 1.0)]
    joints[0].max_force, joints[1].max_force = 0.05, 1e-4
    joints[0].max_bias = joints[1].max_bias = 0.0
    extra = pymunk.PivotJoint(control, body, (0.01, 0.0), (0.01, 0.0))
    extra.max_force = 0.01
    space.add(control, body, pymunk.Circle(body, 0.03), *joints, extra)
    for _ in range(5):
        space.step(0.005)
    return space, [*joints, extra]


def test_joint_impulses_and_chipmunk_constraint_order_survive_a_pickle():
    space, (pivot, gear, extra) = driven_space()
    space.remove(pivot)  # Chipmunk moves the last constraint into the freed slot: its order is now [extra, gear]
    space.add(pivot)
    before = solver_state.capture(space)["constraints"]
    assert [type(c).__name__ for c, _ in before] == ["PivotJoint", "GearJoint", "PivotJoint"]
    assert before[0][0] is extra and all(impulse != (0.0, 0.0) for _, impulse in before[1:2])
    clone = pickle.loads(pickle.dumps(space))
    after = solver_state.capture(clone)["constraints"]
    assert [impulse for _, impulse in after] == [impulse for _, impulse in before]
    assert [c.anchor_a if isinstance(c, pymunk.PivotJoint) else c.ratio for c, _ in after] == [
        c.anchor_a if isinstance(c, pymunk.PivotJoint) else c.ratio for c, _ in before
    ]
    for _ in range(5):
        space.step(0.005)
        clone.step(0.005)
    assert [b.position for b in clone.bodies] == [b.position for b in space.bodies]


def test_shapes_keep_their_hash_ids_after_others_were_removed():
    space = SolverSpace()
    bodies = [pymunk.Body(1.0, 1.0) for _ in range(3)]
    shapes = [pymunk.Circle(b, 0.1) for b in bodies]
    space.add(*bodies, *shapes)
    space.remove(shapes[0], bodies[0])
    clone = pickle.loads(pickle.dumps(space))
    assert sorted(s._hashid for s in clone.shapes) == sorted(s._hashid for s in space.shapes) == [1, 2]


class Begins:
    def __init__(self) -> None:
        self.count = 0

    def begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        self.count += 1


def separated_pair(space_class: type) -> tuple[pymunk.Space, Begins, list[pymunk.Body]]:
    """Two discs that touched and separated in the last substep (their arbiter is cached, not touching)."""
    space, begins = space_class(), Begins()
    space.on_collision(begin=begins.begin)
    bodies = []
    for x, v in ((0.0, 0.5), (0.2, 0.0)):
        body = pymunk.Body(1.0, 1.0)
        body.position, body.velocity = (x, 0.0), (v, 0.0)
        space.add(body, pymunk.Circle(body, 0.1))
        bodies.append(body)
    while begins.count == 0:
        space.step(0.01)
    bodies[0].velocity = (-0.5, 0.0)
    while bodies[1].position.x - bodies[0].position.x <= 0.2:
        space.step(0.01)
    return space, begins, bodies


def touch_again(space: pymunk.Space, begins: Begins) -> list[int]:
    """Drive the discs together again for three substeps (within the collision persistence); begin counts after each."""
    left, right = sorted((b for b in space.bodies), key=lambda b: b.position.x)
    left.velocity, right.velocity = (1.0, 0.0), (0.0, 0.0)
    counts = []
    for _ in range(3):
        space.step(0.01)
        counts.append(begins.count)
    return counts


def test_a_pair_that_separated_just_before_the_pickle_begins_again_when_it_touches():
    """pymunk alone restores the cached arbiter as touching, so the pair's next touch starts no contact."""
    space, begins, _ = separated_pair(SolverSpace)
    clone = pickle.loads(pickle.dumps((space, begins)))
    expected = touch_again(space, begins)
    assert expected[-1] == 2 and touch_again(*clone) == expected
    plain = separated_pair(pymunk.Space)[:2]
    assert touch_again(*pickle.loads(pickle.dumps(plain)))[-1] == 1  # what SolverSpace mends


def test_fixed_entities_are_referred_to_and_move_into_a_restored_world():
    world = World((1.0, 1.0))
    walls = world.add_boundary()
    robot = world.add(DiffDriveRobot("r", (0.5, 0.5), 0.0))
    record = world.fixed_record()
    fixed = record.objects
    assert fixed[0] is walls[0] and robot not in fixed and len(fixed) == 4 * 3  # each wall, its body and its shape
    fresh = pickle.loads(pickle.dumps(record)).fresh().objects  # a record pickles as its objects' pickle
    assert [type(x) for x in fresh] == [type(x) for x in fixed] and fresh[0].space is None
    assert isinstance(fresh[0], Wall) and fresh[0].a == walls[0].a and fresh[2].entity is fresh[0]
    data = snapshot.dumps(world, external=fixed)
    world.release_fixed()
    restored = snapshot.loads(data, external=fixed)
    restored.adopt_fixed(record)
    assert walls[0].space is restored.space and walls[0].shapes[0].space is restored.space
    assert len(restored.space.shapes) == 5 and restored.fixed_record() is record


def test_trails_pack_each_point_once_and_unpack_bit_for_bit():
    archive = TrailArchive()
    trails = {"r": [(0.1, 0.2), (1 / 3, -2.5e-17)]}
    first = archive.pack(trails)
    trails["r"].append((np.nextafter(1.0, 2.0), 0.0))
    second = archive.pack(trails)
    assert first["r"][0] is second["r"][0] and len(second["r"]) == 2  # only the new point was converted
    unpacked, again = TrailArchive.unpack(pickle.loads(pickle.dumps(second)))
    assert unpacked == trails and all(type(x) is float for p in unpacked["r"] for x in p)
    assert len(again.pack(unpacked)["r"]) == 2  # the unpacked archive converts nothing again
    copies, archive_of_copies = archive.copied(trails)
    assert copies == trails and copies["r"] is not trails["r"]
    assert archive_of_copies.pack(copies)["r"][0] is first["r"][0]
    trails["r"] = [(5.0, 5.0)]  # a new list under the same name (a new episode) starts over
    assert len(archive.pack(trails)["r"]) == 1 and archive.pack(trails)["r"][0].tolist() == [[5.0, 5.0]]
