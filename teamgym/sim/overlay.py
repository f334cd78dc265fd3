"""Marks drawn over the world that are not entities: goal points and trajectories."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

from teamgym.sim.canvas import Canvas, Colour, Layer, Point
from teamgym.sim.objects import Lamp


@dataclass
class Overlay:
    """Goal points and paths (world metres) drawn above moving objects, below lamps and robots.

    ``lamp`` is deprecated: add a :class:`~teamgym.sim.objects.Lamp` to the world instead.
    """

    points: list[tuple[Point, Colour]] = field(default_factory=list)
    paths: list[tuple[Sequence[Point], Colour]] = field(default_factory=list)
    lamp: Point | None = None

    draw_layer = Layer.OVERLAY

    def __post_init__(self) -> None:
        if self.lamp is not None:
            warnings.warn(
                "Overlay(lamp=...) is deprecated: add a teamgym.sim.Lamp to the world", DeprecationWarning, stacklevel=3
            )

    def drawables(self) -> list[Overlay | Lamp]:
        """What the renderer draws for this overlay: itself and, if given, the deprecated lamp."""
        return [self] if self.lamp is None else [self, Lamp("overlay lamp", self.lamp)]

    def draw(self, canvas: Canvas) -> None:
        for points, colour in self.paths:
            if len(points) > 1:
                canvas.line(points, colour, 2)
        for point, colour in self.points:
            canvas.cross(point, colour, 0.03)
