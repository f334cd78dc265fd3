"""Physics-and-sensing core of teamgym: a pymunk world with robots, sensors and objects.

Knows nothing about reinforcement learning; environments in :mod:`teamgym.envs` build on it.
"""

from teamgym.sim.categories import Category
from teamgym.sim.entity import Entity
from teamgym.sim.objects import Box, Door, MovingPolygon, StaticPolygon, Target, Wall, regular_polygon
from teamgym.sim.render import Overlay, Renderer, save_gif
from teamgym.sim.robot import DiffDriveRobot, EncoderReading, RobotSpec, body_command, saturate, wheel_speeds, wrap_angle
from teamgym.sim.sensors import KHEPERA_RING, Camera, LightSensor, ProximityRing, Sighting
from teamgym.sim.world import Contact, World

__all__ = [
    "Box",
    "Camera",
    "Category",
    "Contact",
    "DiffDriveRobot",
    "Door",
    "EncoderReading",
    "Entity",
    "KHEPERA_RING",
    "LightSensor",
    "MovingPolygon",
    "Overlay",
    "ProximityRing",
    "Renderer",
    "RobotSpec",
    "Sighting",
    "StaticPolygon",
    "Target",
    "Wall",
    "World",
    "body_command",
    "regular_polygon",
    "save_gif",
    "saturate",
    "wheel_speeds",
    "wrap_angle",
]
