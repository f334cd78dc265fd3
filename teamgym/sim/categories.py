"""Collision categories of the simulator.

Each entity kind has one bit; a shape's ``pymunk.ShapeFilter`` uses it as its category
and the kinds it collides with as its mask. The same number (the bit's index) is the
shape's ``collision_type`` so that contact callbacks can tell kinds apart.
"""

from __future__ import annotations

from enum import IntEnum


class Category(IntEnum):
    """Entity kinds; the value is the bit index used for filters and collision types."""

    WALL = 0
    ROBOT = 1
    OBSTACLE = 2
    BOX = 3
    DOOR = 4
    FURNITURE = 5
    TARGET = 6
    LAMP = 7

    @property
    def bit(self) -> int:
        return 1 << int(self)


#: Kinds that physically collide with each other (targets and lamps are points, they collide with nothing).
SOLID = (
    Category.WALL.bit | Category.ROBOT.bit | Category.OBSTACLE.bit | Category.BOX.bit | Category.DOOR.bit | Category.FURNITURE.bit
)

#: Kinds a proximity ray or the light path can hit.
RAY_HITS = SOLID
#: Kinds that block light: everything solid except boxes, which are clear plastic (paper 004).
OPAQUE = SOLID & ~Category.BOX.bit
