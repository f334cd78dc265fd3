"""Physics-and-sensing core of teamgym: a pymunk world with robots, sensors and objects.

Knows nothing about reinforcement learning; environments in :mod:`teamgym.envs` build on it.
"""

from teamgym.sim.canvas import Canvas, Layer
from teamgym.sim.categories import Category
from teamgym.sim.channel import Channel, ChannelConfig, Message
from teamgym.sim.contacts import Contact
from teamgym.sim.entity import Entity
from teamgym.sim.objects import Box, Door, Lamp, MovingPolygon, StaticPolygon, Target, Wall, regular_polygon
from teamgym.sim.render import Overlay, Renderer, save_gif
from teamgym.sim.robot import DiffDriveRobot, EncoderReading, RobotSpec, body_command, saturate, wheel_speeds, wrap_angle
from teamgym.sim.sensors import (
    KHEPERA_RING,
    Camera,
    LightSensor,
    ProximityRing,
    Sensor,
    SensorSuite,
    Sighting,
    WheelEncoders,
)
from teamgym.sim.world import World

__all__ = [
    "Box",
    "Camera",
    "Canvas",
    "Category",
    "Channel",
    "ChannelConfig",
    "Contact",
    "DiffDriveRobot",
    "Door",
    "EncoderReading",
    "Entity",
    "KHEPERA_RING",
    "Lamp",
    "Layer",
    "LightSensor",
    "Message",
    "MovingPolygon",
    "Overlay",
    "ProximityRing",
    "Renderer",
    "RobotSpec",
    "Sensor",
    "SensorSuite",
    "Sighting",
    "StaticPolygon",
    "Target",
    "Wall",
    "WheelEncoders",
    "World",
    "body_command",
    "regular_polygon",
    "save_gif",
    "saturate",
    "wheel_speeds",
    "wrap_angle",
]
