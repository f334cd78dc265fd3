"""Marks drawn over the world that are not entities: goal points and trajectories."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from teamgym.sim.canvas import Canvas, Colour, Layer, Point


@dataclass
class Overlay:
    """Goal points and paths (world metres) drawn above moving objects, below lamps and robots.

    Anything with a place in the world (a lamp, a target) is an entity that draws itself instead.
    """

    points: list[tuple[Point, Colour]] = field(default_factory=list)
    paths: list[tuple[Sequence[Point], Colour]] = field(default_factory=list)

    draw_layer = Layer.OVERLAY

    def drawables(self) -> list[Overlay]:
        """What the renderer draws for this overlay."""
        return [self]

    def draw(self, canvas: Canvas) -> None:
        for points, colour in self.paths:
            if len(points) > 1:
                canvas.line(points, colour, 2)
        for point, colour in self.points:
            canvas.cross(point, colour, 0.03)
