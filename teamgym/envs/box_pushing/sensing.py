"""BoxPushing's sensing phase over one or many env copies: ring, light and encoders, stalls, executors.

:func:`read_sensors` reads the robots that go on in each copy given (a lone env: its own;
a batch: every copy of the step's group) and writes their rows of the copies'
:class:`~teamgym.envs.box_pushing.state.BoxPushingArrays`. It casts the proximity rays of
every copy's robots in one pass, each in its copy's own space (a lone env: robot after robot),
and draws each copy's noise from the copy's own stream, one block of standard normals for all
its robots, robot after robot and sensor after sensor, as
:class:`~teamgym.sim.sensors.SensorSuite` does (the stream a loop over the robots would draw).
The rest is one numpy pass over the rows of every copy: the unshadowed light (the lamp is the
config's, the same in every copy), the wheel encoders, the gains and noise of each sensor,
the stall counters. The primitive executors then see each robot's readings (paper 004,
section 3.1: "no-rotation" is read from the encoders).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from teamgym.sim.robot import wheel_slip, wheel_slips
from teamgym.sim.sensors import encoder_rows

if TYPE_CHECKING:
    from teamgym.envs.box_pushing.env import BoxPushing

__all__ = ["STALL_SLIP", "read_sensors"]

#: Wheel slip above which a robot with commanded motion counts as stalled.
STALL_SLIP = 0.9


def read_sensors(sensed: list[tuple[BoxPushing, list[str]]], memo: dict[int, tuple] | None = None) -> None:
    """Readings of the robots ``agents`` of each ``(env, agents)`` (copies sharing one ``BoxPushingArrays``).

    ``memo``: a batch's per-world lists of the sensed robots, kept between steps (:func:`_sensed_rows`).
    """
    sensed = [(env, agents) for env, agents in sensed if agents]
    if not sensed:
        return
    first = sensed[0][0]
    team, ring, light = first._arrays, first.ring, first.light
    encoders, slices = first.sensors.sensors["encoders"], first.sensors.slices
    sizes = (ring.noise_size, light.noise_size, encoders.noise_size)
    drawn = sum(sizes)
    one = len(sensed) == 1
    if one:
        env, agents = sensed[0]
        world = env.world
        robots = [env.robots[a] for a in agents]
        at = world.robot_states[[world.robot_rows[a] for a in agents]]
        block = np.empty((len(agents), first.sensors.width), dtype=np.float32)
        env.ring.read_values(world, robots, at, block[:, slices["proximity"]], None)
        if light.blockers:  # shadows: line-of-sight queries in the copy's space
            env.light.read_values(world, robots, at, block[:, slices["light"]], None)
        noise = [env.np_random.standard_normal((len(agents), drawn))] if drawn else []
        copies, rows = [env._copy] * len(agents), [env._row[a] for a in agents]
    else:
        copies, rows, robots, poses, noise, spaces = [], [], [], [], [], []
        for env, agents in sensed:
            mine, own_rows, index = _sensed_rows(env, agents, memo)
            states = env.world.robot_states
            poses.append(states if index is None else states[index])
            spaces += [env.world.space] * len(agents)
            if drawn:
                noise.append(env.np_random.standard_normal((len(agents), drawn)))
            copies += [env._copy] * len(agents)
            rows += own_rows
            robots += mine
        at = np.concatenate(poses)
        block = np.empty((len(robots), first.sensors.width), dtype=np.float32)
        if light.blockers:
            j = 0
            for env, agents in sensed:
                part = block[j : j + len(agents), slices["light"]]
                env.light.read_values(env.world, robots[j : j + len(agents)], at[j : j + len(agents)], part, None)
                j += len(agents)
    if not one:  # every copy's rings in one pass (ProximityRing.read_many: the same bits as robot by robot)
        ring.read_many(spaces, robots, at, block[:, slices["proximity"]])
    z = (noise[0] if one else np.concatenate(noise)) if drawn else None
    if not light.blockers:
        if one:  # a lone env's few robots: 5.4 µs per-robot against 14.5 µs as arrays for 2 robots (timeit, this session)
            light.shine_rows(at[:, :3].tolist(), block[:, slices["light"]])
        else:
            light.shine_array(at, block[:, slices["light"]])
    gains = team.light_gains[copies, rows] if light.gain_spread else None
    raw = None if one else encoder_rows(robots)  # a batch: every robot's wheel rotations of the step in one array
    start = 0
    for sensor, name, size in zip((ring, light, encoders), ("proximity", "light", "encoders"), sizes):
        part = z[:, start : start + size] if size else None
        if sensor is not encoders:
            sensor.apply_noise(part, block[:, slices[name]], robots, gains if sensor is light else None)
        elif raw is None:  # a lone env's few robots cost less robot by robot
            encoders.read_drawn(None, robots, at, part, block[:, slices[name]])
        else:
            encoders.read_raw(raw, part, block[:, slices[name]])
        start += size
    if one:  # one copy (a lone env): its rows, robot after robot
        stalled = [wheel_slip(*robot.encoder_row[:4]) > STALL_SLIP for robot in robots]
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
        stalled = wheel_slips(raw) > STALL_SLIP
        team.readings[copies, rows] = block
        team.stalled[copies, rows] += stalled
        team.stall_run[copies, rows] = (team.stall_run[copies, rows] + 1) * stalled
    if first._primitives is not None:
        proximity, wheels = block[:, slices["proximity"]], block[:, slices["encoders"]]
        j = 0
        for env, agents in sensed:
            executors = env._primitives.executors
            for agent in agents:
                executors[agent].observe(proximity[j], wheels[j])  # PrimitiveAction.observe, without its call
                j += 1


def _sensed_rows(env: BoxPushing, agents: list[str], memo: dict[int, tuple] | None) -> tuple[list, list[int], list[int] | None]:
    """``agents``' robots, their rows in ``possible_agents`` order and in the world's robot states (``None``: all of
    them in order), kept in ``memo`` while the same world, robots and agents come back (a batch's every step)."""
    world = env.world
    known = memo.get(id(world)) if memo is not None else None
    if known is not None and known[0] is world and known[1] is world.robot_rows and known[2] == agents:
        return known[3]
    index = [world.robot_rows[a] for a in agents]
    whole = index == list(range(len(world.robot_states)))
    found = ([env.robots[a] for a in agents], [env._row[a] for a in agents], None if whole else index)
    if memo is not None:
        memo[id(world)] = (world, world.robot_rows, list(agents), found)
    return found
