"""What an entity draws itself on: a Pillow pen, the world-to-pixel transform and the scale.

Drawing order is by :class:`Layer` (lowest first); within a layer, things are drawn in the
order they were added to the world.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from enum import IntEnum
from typing import Protocol

from PIL import ImageDraw

Point = tuple[float, float]
Colour = tuple[int, int, int]

ROBOT_COLOURS: list[Colour] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
    (188, 189, 34),
]


def robot_colour(index: int) -> Colour:
    """Colour of the ``index``-th robot (the palette repeats after eight)."""
    return ROBOT_COLOURS[index % len(ROBOT_COLOURS)]


class Layer(IntEnum):
    """Drawing layers, bottom to top."""

    STATIC = 0  #: walls, doors, furniture
    MOVING = 10  #: moving obstacles, boxes
    MARKS = 20  #: targets
    OVERLAY = 30  #: an :class:`~teamgym.sim.overlay.Overlay`'s paths and goal points
    LAMPS = 40  #: lamps
    ROBOTS = 50  #: robots


class Canvas:
    """A frame being drawn: ``pen`` (``PIL.ImageDraw``), ``px`` (world metres to pixels), ``scale`` (px/m).

    The helpers take world coordinates; sizes given in pixels say so in their name.
    """

    def __init__(self, pen: ImageDraw.ImageDraw, px: Callable[[float, float], Point], scale: float) -> None:
        self.pen = pen
        self.px = px
        self.scale = float(scale)
        self._counters: dict[str, int] = {}

    def take_index(self, key: str) -> int:
        """0, 1, 2, ... on successive calls with the same ``key`` during this frame (e.g. robot colours)."""
        index = self._counters.get(key, 0)
        self._counters[key] = index + 1
        return index

    def stroke(self, thickness: float) -> int:
        """Line width in pixels of something ``thickness`` metres wide (at least 1)."""
        return max(1, int(thickness * self.scale))

    def line(self, points: Sequence[Point], colour: Colour, width_px: int = 1) -> None:
        """A polyline through ``points``."""
        px = self.px
        self.pen.line([px(*p) for p in points], fill=colour, width=width_px)

    def polygon(self, vertices: Sequence[Point], fill: Colour, outline: Colour) -> None:
        px = self.px
        self.pen.polygon([px(*v) for v in vertices], fill=fill, outline=outline)

    def disc(self, centre: Point, radius_px: float, fill: Colour, outline: Colour) -> Point:
        """A filled circle of ``radius_px`` pixels; returns the centre in pixels."""
        cx, cy = self.px(*centre)
        r = radius_px
        self.pen.ellipse([cx - r, cy - r, cx + r, cy + r], fill=fill, outline=outline)
        return cx, cy

    def cross(self, point: Point, colour: Colour, size: float) -> None:
        """An ×, ``size`` metres from centre to tip (at least 3 px)."""
        cx, cy = self.px(*point)
        s = max(3.0, size * self.scale)
        self.pen.line([(cx - s, cy - s), (cx + s, cy + s)], fill=colour, width=2)
        self.pen.line([(cx - s, cy + s), (cx + s, cy - s)], fill=colour, width=2)


class Drawable(Protocol):
    """Anything the renderer draws: entities, overlays."""

    @property
    def draw_layer(self) -> int: ...

    def draw(self, canvas: Canvas) -> None: ...
