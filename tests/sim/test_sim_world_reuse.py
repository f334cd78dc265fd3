"""World.step(reuse_states=True) continues exactly as a step that reads the space again."""

from __future__ import annotations

import numpy as np

import teamgym


def test_reusing_the_last_read_changes_nothing():
    fresh, reused = (teamgym.make("Navigation-v0", n_robots=3, actuation_delay=0.05) for _ in range(2))
    for env in (fresh, reused):
        env.reset(seed=4)
    rng = np.random.default_rng(0)
    for _ in range(60):
        commands = rng.uniform([-0.3, -8.0], [0.3, 8.0], size=(3, 2)).tolist()
        for env, reuse in ((fresh, False), (reused, True)):
            for robot, (v, omega) in zip(env.robot_list, commands):
                robot.set_command(v, omega)
            env.world.step(reuse_states=reuse)
        assert np.array_equal(fresh.world.states, reused.world.states)
        assert [r.odometer for r in fresh.robot_list] == [r.odometer for r in reused.robot_list]


def test_a_world_that_was_never_read_reads_anyway():
    env = teamgym.make("Navigation-v0", n_robots=2)
    env.reset(seed=1)
    world = env.world
    world._reader = None  # as after adding or removing an entity
    world.step(reuse_states=True)
    assert world.states.shape == (len(world._stepped), 6)
