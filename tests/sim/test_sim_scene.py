"""A static scene carried over to the next episode's world gives the world a fresh build gives.

Rendezvous-v0 and Exploration-v0 place the same wall, door and furniture entities in every
episode's world (:mod:`teamgym.sim.scene`); the recorded rollouts of the observation-hash
fixture must come out of an env's second episode as they come out of a fresh env's first.
"""

import json

import numpy as np
import pytest
from regression import OBS_FIXTURE, OBS_SEEDS, _random_value, obs_cases, obs_hash

import teamgym
from teamgym.registry import make
from teamgym.sim import Category, DiffDriveRobot, Door, MovingPolygon, RobotSpec, StaticPolygon, Wall, World
from teamgym.sim.scene import StaticScene

RECORDED = json.loads(OBS_FIXTURE.read_text())["cases"]
SCENE_CASES = sorted(name for name, (env_id, _) in obs_cases().items() if env_id in ("Rendezvous-v0", "Exploration-v0"))


def _played(env_id: str, **config):
    """A new env after 40 random steps of an episode of another seed (robots touch walls in velocity mode)."""
    env = make(env_id, **config)
    _, infos = env.reset(seed=977)
    rng = np.random.default_rng(977)
    for _ in range(40):
        if not env.agents:
            break
        actions = {a: _random_value(env.action_space(a), infos[a].get("action_mask"), rng, env) for a in env.agents}
        _, _, _, _, infos = env.step(actions)
    return env


@pytest.mark.parametrize("name", SCENE_CASES)
def test_a_second_episode_gives_the_recorded_rollout(name, monkeypatch):
    env_id, config = obs_cases()[name]
    monkeypatch.setattr(teamgym, "make", _played)
    assert obs_hash(env_id, config, OBS_SEEDS[0]) == RECORDED[name]["hashes"][0]


def _scene():
    return StaticScene(
        [
            Wall("w0", (0.0, 0.0), (1.0, 0.0)),
            Door("d0", (1.0, 0.0), (1.0, 1.0), is_open=False),
            StaticPolygon("f0", [(0.2, 0.2), (0.4, 0.2), (0.3, 0.4)]),
        ]
    )


def _robot(world: World) -> DiffDriveRobot:
    return world.add(DiffDriveRobot("r0", (0.5, 0.5), 0.0, RobotSpec()))


def test_place_moves_the_scene_and_leaves_the_other_entities():
    scene = _scene()
    first = World((1.0, 1.0))
    scene.place(first)
    robot = _robot(first)
    second = World((1.0, 1.0))
    scene.place(second)
    assert list(first.entities) == ["r0"] and first.robots == [robot]
    assert list(second.entities) == ["w0", "d0", "f0"] and scene.world is second
    assert [s.entity.name for s in second.space.shapes] == ["w0", "d0", "f0"]
    assert not first.space.shapes - set(robot.shapes)


def test_placed_scene_gives_the_space_of_a_fresh_build():
    def drive(world: World) -> None:
        robot = world.add(DiffDriveRobot("r0", (0.6, 0.1), -1.5, RobotSpec()))  # into wall w0 and along it
        robot.set_command(0.3, 0.5)
        for _ in range(30):
            world.step()

    reused = _scene()
    first = World((1.0, 1.0))
    reused.place(first)
    drive(first)
    assert first.total_contacts("r0") > 0
    again, fresh = World((1.0, 1.0)), World((1.0, 1.0))
    reused.place(again)
    for entity in _scene().entities:
        fresh.add(entity)
    for world in (again, fresh):
        drive(world)
    np.testing.assert_array_equal(again.states, fresh.states)
    assert again.total_contacts("r0") == fresh.total_contacts("r0") > 0
    assert [s.entity.name for s in again.space.shapes] == [s.entity.name for s in fresh.space.shapes]
    assert [s.bb for s in again.space.shapes] == [s.bb for s in fresh.space.shapes]


def test_a_rejected_place_changes_nothing():
    scene = _scene()
    first = World((1.0, 1.0))
    scene.place(first)
    clashing = World((1.0, 1.0))
    clashing.add(Wall("d0", (0.0, 1.0), (1.0, 1.0)))
    with pytest.raises(ValueError, match="already has entities named \\['d0'\\]"):
        scene.place(clashing)
    assert scene.world is first and list(first.entities) == ["w0", "d0", "f0"]
    assert list(clashing.entities) == ["d0"]


def test_release_skips_entities_removed_by_hand_and_a_door_keeps_its_state():
    scene = _scene()
    world = World((1.0, 1.0))
    scene.place(world)
    world.remove("w0")
    scene.release()
    assert not world.entities and scene.world is None
    door = scene.entities[1]
    door.open()
    scene.place(world)
    assert list(world.entities) == ["w0", "d0", "f0"] and door.is_open and not door.shapes


def test_scene_refuses_moving_entities_and_repeated_names():
    with pytest.raises(ValueError, match="moving ones: \\['m'\\]"):
        StaticScene([MovingPolygon("m", [(0, 0), (0.1, 0), (0, 0.1)], (0.5, 0.5), (0.1, 0.0))])
    with pytest.raises(ValueError, match="repeat: \\['w'\\]"):
        StaticScene([Wall("w", (0, 0), (1, 0)), Wall("w", (0, 1), (1, 1))])


def test_remove_many_is_all_or_nothing():
    world = World((1.0, 1.0))
    for entity in _scene().entities:
        world.add(entity)
    with pytest.raises(KeyError, match="no entity named 'x'"):
        world.remove_many(["w0", "x"])
    with pytest.raises(KeyError, match="repeat"):
        world.remove_many(["w0", "w0"])
    assert list(world.entities) == ["w0", "d0", "f0"] and len(world.space.shapes) == 3
    assert [e.name for e in world.remove_many(["f0", "w0"])] == ["f0", "w0"]
    assert list(world.entities) == ["d0"] and len(world.space.shapes) == 1


def test_entities_added_one_by_one_are_grouped_as_a_regroup_groups_them():
    world = World((2.0, 2.0))
    spec = RobotSpec()
    world.add(Wall("w", (0, 0), (1, 0)))
    world.add(MovingPolygon("m0", [(0, 0), (0.1, 0), (0, 0.1)], (1.5, 1.5), (0.1, 0.0)))
    world.add(DiffDriveRobot("r0", (0.5, 0.5), 0.0, spec))
    world.add(StaticPolygon("f", [(1.2, 0.2), (1.4, 0.2), (1.3, 0.4)]))
    world.add(MovingPolygon("m1", [(0, 0), (0.1, 0), (0, 0.1)], (1.5, 0.5), (0.0, 0.1)))
    world.add(DiffDriveRobot("r1", (0.5, 1.0), 0.0, spec))
    grouped = (list(world.robots), list(world.movers), world.tracked(), dict(world.robot_rows), list(world._stepped))
    rows = dict(world._rows_of)
    world._regroup()
    assert (list(world.robots), list(world.movers), world.tracked(), dict(world.robot_rows), list(world._stepped)) == grouped
    assert world._rows_of == rows
    assert [e.name for e in world._stepped] == ["r0", "r1", "m0", "m1"]
    assert rows == {Category.ROBOT: slice(0, 2), Category.OBSTACLE: slice(2, 4)}
