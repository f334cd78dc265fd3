"""Privileged robot recognition for the ``sbs`` baseline: a diagnostic, not the paper's method.

Paper 004 recognizes other robots only through the M check (section 2.4: a change of sensor
data while the robot stands still). ``--policy sbs-oracle`` replaces that procedure with the
simulator's ground truth, so an experiment can tell whether the situated behaviour sets fail
because robots do not recognize each other or in spite of recognizing them perfectly.

What the oracle reports is what a perfect M check could report, nothing more: a robot is
recognized while its body is within ``sensor_range`` of the observer's body *and* it moved
(more than ``change_threshold``) during the last ``mark_patience`` steps, the same patience
after which the sensor recognizer forgets a robot that stopped (two robots stopped face to
face would otherwise wait for ever, B-14). Its bearing, in the observer's frame, picks the
sensor group; everything else (``X-robot-leaving``, M, Tm) follows from the recognizer.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from teamgym.sim.robot import wrap_angle


class TrueRobotBearings:
    """Bearings of the moving robots each robot would sense, from the simulator's state."""

    def __init__(self, sensor_range: float, change_threshold: float, patience: int) -> None:
        self.sensor_range = sensor_range
        self.change_threshold = change_threshold
        self.patience = patience
        self._history: dict[str, deque[tuple[float, float]]] = {}

    def reset(self) -> None:
        self._history.clear()

    def update(self, env) -> dict[str, list[float]]:
        """Per live robot of ``env``: bearings (rad, CCW from its heading) of the moving robots in range."""
        poses = {agent: robot.pose for agent, robot in env.robots.items()}
        moving = {agent: self._moved(agent, pose[:2]) for agent, pose in poses.items()}
        reach = self.sensor_range + 2.0 * env.spec_robot.radius
        bearings: dict[str, list[float]] = {}
        for agent in env.live_agents:  # not env.agents: with fixed_agents=True that includes absent spares
            x, y, heading = poses[agent]
            bearings[agent] = [
                float(wrap_angle(math.atan2(oy - y, ox - x) - heading))
                for other, (ox, oy, _) in poses.items()
                if other != agent and moving[other] and math.hypot(ox - x, oy - y) < reach
            ]
        for gone in set(self._history) - set(poses):
            del self._history[gone]
        return bearings

    def _moved(self, agent: str, position: tuple[float, float]) -> bool:
        history = self._history.setdefault(agent, deque(maxlen=self.patience + 1))
        history.append(position)
        if len(history) <= self.patience:
            return True  # a robot that just appeared has not been watched standing still yet
        points = np.asarray(history)
        return bool(np.max(np.linalg.norm(points - points[-1], axis=1)) > self.change_threshold)
