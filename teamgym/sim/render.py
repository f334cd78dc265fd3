"""Top-down rendering of a world to a numpy image (headless) or a window, and GIF export.

``rgb_array`` rendering uses Pillow only and needs no display. The ``human`` mode opens a
pygame window (imported lazily, so headless use never touches it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from operator import attrgetter
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from teamgym.sim.canvas import ROBOT_COLOURS, Canvas, Drawable, robot_colour
from teamgym.sim.overlay import Overlay
from teamgym.sim.world import World

__all__ = ["ROBOT_COLOURS", "Overlay", "Renderer", "robot_colour", "save_gif"]


class Renderer:
    """Draws a :class:`World` top-down with ``pixels_per_metre`` resolution.

    Every entity draws itself (:meth:`~teamgym.sim.entity.Entity.draw`), layer by layer
    (:class:`~teamgym.sim.canvas.Layer`), in the order added within a layer.
    """

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
        """Return an ``(height, width, 3)`` uint8 image of the world (and ``overlay``)."""
        image = Image.new("RGB", (self.width, self.height), (250, 250, 247))
        canvas = Canvas(ImageDraw.Draw(image), self.to_pixels, self.scale)
        items: list[Drawable] = [*self.world.entities.values(), *(overlay.drawables() if overlay is not None else ())]
        for item in sorted(items, key=attrgetter("draw_layer")):
            item.draw(canvas)
        return np.asarray(image)

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
