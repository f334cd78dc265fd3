"""Contacts are counted in one place: per entity name, per control step and since the world was built."""

import numpy as np
import pytest

from teamgym.sim import Box, DiffDriveRobot, World

NAMES = ["r0", "r1", "r2", "wall_east", "box", "nobody"]


def scripted_world():
    """r0 drives into the east wall; r1 and r2 drive head-on into each other; r2 later backs off and returns."""
    world = World((1.0, 1.0))
    world.add_boundary()
    world.add(DiffDriveRobot("r0", (0.9, 0.5), 0.0))  # rim 7.25 cm from the wall: touches in step 3 at 0.3 m/s
    world.add(DiffDriveRobot("r1", (0.3, 0.2), 0.0))
    world.add(DiffDriveRobot("r2", (0.45, 0.2), np.pi))  # gap 9.5 cm closing at 0.4 m/s: touch in step 3
    world.add(Box("box", (0.05, 0.05), (0.5, 0.8), 0.5))
    return world


def script(world, step):
    world["r0"].set_command(0.3, 0.0)
    backing_off = 6 <= step < 9  # r1 waits while r2 backs off for 3 steps; then both drive again
    world["r1"].set_command(0.0 if backing_off else 0.2, 0.0)
    world["r2"].set_command(-0.2 if backing_off else 0.2, 0.0)


def test_counts_match_a_hand_count():
    world = scripted_world()
    hand_total = dict.fromkeys(NAMES, 0)
    for step in range(14):
        script(world, step)
        world.step()
        hand_new = dict.fromkeys(NAMES, 0)
        for contact in world.contacts:  # what every env used to do
            for name in (contact.a, contact.b):
                hand_new[name] = hand_new.get(name, 0) + 1
                hand_total[name] = hand_total.get(name, 0) + 1
        assert world.contacts_per(NAMES).tolist() == [hand_new[n] for n in NAMES]
        assert world.contacts_per(NAMES, total=True).tolist() == [hand_total[n] for n in NAMES]
        assert [world.new_contacts(n) for n in NAMES] == [hand_new[n] for n in NAMES]
        assert [world.total_contacts(n) for n in NAMES] == [hand_total[n] for n in NAMES]
        assert world.contact_counts() == {n: c for n, c in hand_new.items() if c}
        if step == 2:  # both collisions begin in the third step, once each, one count per side
            assert sorted(tuple(sorted((c.a, c.b))) for c in world.contacts) == [("r0", "wall_east"), ("r1", "r2")]
            assert world.contact_counts() == {"r0": 1, "wall_east": 1, "r1": 1, "r2": 1}
        if 3 <= step < 9:  # in touch or apart: nothing new begins
            assert world.contacts == []
    # r2 came back and hit r1 again; r0 stayed on the wall; nobody touched the box.
    assert world.contact_counts(total=True) == {"r0": 1, "wall_east": 1, "r1": 2, "r2": 2}
    counts = world.contacts_per(NAMES, total=True)
    assert counts.dtype == np.int64 and counts.tolist() == [1, 2, 2, 1, 0, 0]


def test_totals_survive_removal_and_steps_without_contacts():
    world = scripted_world()
    for step in range(4):
        script(world, step)
        world.step()
    world.remove("r0")
    world.step()
    assert world.new_contacts("r0") == 0 and world.total_contacts("r0") == 1
    assert world.contacts_per([]).shape == (0,)


@pytest.mark.parametrize("name", ["r1", "r2"])
def test_contacts_of_lists_the_last_step(name):
    world = scripted_world()
    for step in range(3):
        script(world, step)
        world.step()
    assert len(world.contacts_of(name)) == world.new_contacts(name) == 1
