"""BoxPushing's sensing phase over one or many env copies: ring, light and encoders, stalls, executors.

:func:`read_sensors` reads the robots that go on in each copy given (a lone env: its own;
a batch: every copy of the step's group) and writes their rows of the copies'
:class:`~teamgym.envs.box_pushing.state.BoxPushingArrays`. Noise-free sensors draw
nothing, so they are read sensor after sensor over all rows at once: the proximity ring in
each copy's space, the unshadowed light of every copy's robots in one numpy pass (the lamp is
the config's, the same in every copy), the wheel encoders of all robots together. Noisy
sensors are read robot after robot within each copy (:class:`~teamgym.sim.sensors.SensorSuite`),
so each copy draws its noise exactly as a lone env does. Stall counters and the primitive
executors (paper 004, section 3.1: "no-rotation" is read from the encoders) follow.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from teamgym.envs.box_pushing.env import BoxPushing

__all__ = ["STALL_SLIP", "read_sensors"]

#: Wheel slip above which a robot with commanded motion counts as stalled.
STALL_SLIP = 0.9


def read_sensors(sensed: list[tuple[BoxPushing, list[str]]]) -> None:
    """Readings of the robots ``agents`` of each ``(env, agents)`` (copies sharing one ``BoxPushingArrays``)."""
    sensed = [(env, agents) for env, agents in sensed if agents]
    if not sensed:
        return
    first = sensed[0][0]
    suite, team = first.sensors, first._arrays
    slices = suite.slices
    copies, rows, robots, blocks = [], [], [], []
    for env, agents in sensed:
        world, row = env.world, env._row
        mine = [env.robots[a] for a in agents]
        poses = world.robot_states[[world.robot_rows[a] for a in agents]]
        block = np.empty((len(agents), suite.width), dtype=np.float32)
        if first._noiseless:
            env.ring.read_rows(world, mine, poses, None, block[:, slices["proximity"]])
            if env.light.blockers:
                env.light.read_rows(world, mine, poses, None, block[:, slices["light"]])
        else:
            index = [row[a] for a in agents]
            gains = {"light": team.light_gains[env._copy, index]} if env.light.gain_spread else None
            env.sensors.read_rows(world, mine, poses, env.np_random, block, gains)  # its own noise
        copies += [env._copy] * len(agents)
        rows += [row[a] for a in agents]
        robots += mine
        blocks.append((block, poses))
    block = blocks[0][0] if len(blocks) == 1 else np.concatenate([b for b, _ in blocks])
    if first._noiseless:
        poses = blocks[0][1] if len(blocks) == 1 else np.concatenate([p for _, p in blocks])
        if not first.light.blockers:
            first.light.shine_rows(poses[:, :3].tolist(), block[:, slices["light"]])
        suite.sensors["encoders"].read_rows(None, robots, poses, None, block[:, slices["encoders"]])
    stalled = [robot.encoders.slip > STALL_SLIP for robot in robots]
    if len(sensed) == 1:  # one copy (a lone env): its rows, robot after robot
        k = copies[0]
        team.readings[k, rows] = block
        counts, runs = team.stalled[k], team.stall_run[k]
        for i, hit in zip(rows, stalled):
            if hit:
                counts[i] += 1
                runs[i] += 1
            else:
                runs[i] = 0
    else:
        team.readings[copies, rows] = block
        hits = np.array(stalled)
        team.stalled[copies, rows] += hits
        team.stall_run[copies, rows] = (team.stall_run[copies, rows] + 1) * hits
    primitives = first._primitives
    if primitives is not None:
        proximity, encoders = block[:, slices["proximity"]], block[:, slices["encoders"]]
        j = 0
        for env, agents in sensed:
            primitives = env._primitives
            for agent in agents:
                primitives.observe(agent, proximity[j], encoders[j])
                j += 1
