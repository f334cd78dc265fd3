"""Top-down rendering of a world to a numpy image (headless) or a window, and GIF export.

``rgb_array`` rendering uses Pillow only and needs no display. The ``human`` mode opens a
pygame window (imported lazily, so headless use never touches it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from teamgym.sim.objects import Box, Door, MovingPolygon, StaticPolygon, Target, Wall
from teamgym.sim.robot import DiffDriveRobot
from teamgym.sim.world import World

ROBOT_COLOURS = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
    (188, 189, 34),
]


def robot_colour(index: int) -> tuple[int, int, int]:
    return ROBOT_COLOURS[index % len(ROBOT_COLOURS)]


@dataclass
class Overlay:
    """Extra marks drawn on top of the world: goal points and trajectories (world metres)."""

    points: list[tuple[tuple[float, float], tuple[int, int, int]]] = field(default_factory=list)
    paths: list[tuple[Sequence[tuple[float, float]], tuple[int, int, int]]] = field(default_factory=list)
    lamp: tuple[float, float] | None = None


class Renderer:
    """Draws a :class:`World` top-down with ``pixels_per_metre`` resolution."""

    def __init__(self, world: World, pixels_per_metre: float = 200.0, margin: float = 0.05) -> None:
        self.world = world
        self.scale = float(pixels_per_metre)
        self.margin = float(margin)
        w, h = world.size
        self.width = int(math.ceil((w + 2 * margin) * self.scale))
        self.height = int(math.ceil((h + 2 * margin) * self.scale))
        self._window = None
        self._clock = None

    def to_pixels(self, x: float, y: float) -> tuple[float, float]:
        """World metres to image pixels (y axis up in the world, down in the image)."""
        return ((x + self.margin) * self.scale, self.height - (y + self.margin) * self.scale)

    def draw(self, overlay: Overlay | None = None) -> np.ndarray:
        """Return an ``(height, width, 3)`` uint8 image of the world."""
        image = Image.new("RGB", (self.width, self.height), (250, 250, 247))
        pen = ImageDraw.Draw(image)
        px = self.to_pixels
        robot_index = 0
        for entity in self.world.entities.values():
            if isinstance(entity, Door):
                colour = (120, 200, 120) if entity.is_open else (150, 60, 40)
                width = 1 if entity.is_open else max(1, int(entity.thickness * self.scale))
                pen.line([px(*entity.a), px(*entity.b)], fill=colour, width=width)
            elif isinstance(entity, Wall):
                pen.line([px(*entity.a), px(*entity.b)], fill=(40, 40, 40), width=max(1, int(entity.thickness * self.scale)))
            elif isinstance(entity, StaticPolygon):
                pen.polygon([px(*v) for v in entity.vertices], fill=(180, 180, 180), outline=(90, 90, 90))
            elif isinstance(entity, (MovingPolygon, Box)):
                body = entity.body
                verts = [px(*body.local_to_world(v)) for v in entity.local_vertices]
                fill = (220, 80, 80) if isinstance(entity, MovingPolygon) else (205, 170, 110)
                pen.polygon(verts, fill=fill, outline=(60, 30, 30))
            elif isinstance(entity, Target):
                self._cross(pen, entity.position, (200, 0, 0), entity.radius)
        if overlay is not None:
            for points, colour in overlay.paths:
                if len(points) > 1:
                    pen.line([px(*p) for p in points], fill=colour, width=2)
            for point, colour in overlay.points:
                self._cross(pen, point, colour, 0.03)
            if overlay.lamp is not None:
                lx, ly = px(*overlay.lamp)
                pen.ellipse([lx - 8, ly - 8, lx + 8, ly + 8], fill=(255, 220, 0), outline=(120, 100, 0))
        for entity in self.world.entities.values():
            if isinstance(entity, DiffDriveRobot):
                x, y, theta = entity.pose
                r = entity.spec.radius * self.scale
                cx, cy = px(x, y)
                colour = robot_colour(robot_index) if entity.enabled else (120, 120, 120)
                pen.ellipse([cx - r, cy - r, cx + r, cy + r], fill=colour, outline=(0, 0, 0))
                pen.line([(cx, cy), (cx + r * math.cos(theta), cy - r * math.sin(theta))], fill=(255, 255, 255), width=2)
                robot_index += 1
        return np.asarray(image)

    def _cross(self, pen: ImageDraw.ImageDraw, point: tuple[float, float], colour, size: float) -> None:
        cx, cy = self.to_pixels(*point)
        s = max(3.0, size * self.scale)
        pen.line([(cx - s, cy - s), (cx + s, cy + s)], fill=colour, width=2)
        pen.line([(cx - s, cy + s), (cx + s, cy - s)], fill=colour, width=2)

    def show(self, frame: np.ndarray, fps: int) -> None:
        """Show a frame in a pygame window (``human`` render mode)."""
        import pygame

        if self._window is None:
            pygame.init()
            self._window = pygame.display.set_mode((self.width, self.height))
            pygame.display.set_caption("teamgym")
            self._clock = pygame.time.Clock()
        pygame.event.pump()
        surface = pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2)))
        self._window.blit(surface, (0, 0))
        pygame.display.flip()
        self._clock.tick(fps)

    def close(self) -> None:
        if self._window is not None:
            import pygame

            pygame.display.quit()
            self._window = None

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_window"] = None
        state["_clock"] = None
        return state


def save_gif(frames: Sequence[np.ndarray], path: str | Path, fps: float = 10.0) -> Path:
    """Write RGB frames to an animated GIF at ``path`` and return the path."""
    if len(frames) == 0:
        raise ValueError("save_gif needs at least one frame")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(round(1000 / fps)), loop=0, optimize=False)
    return path
