"""Frames are pixel-identical to the renderer before entities drew themselves.

``legacy_draw`` is the pre-refactor ``Renderer.draw`` (an ``isinstance`` chain over the
world's entities, then the overlay, then the robots) kept here as the reference; the
recorded SHA-256 digests pin the same frames for the Pillow version they were made with.
The scenes add static geometry before moving objects and targets, as the envs do: the
old renderer drew all of them in insertion order, the new one by layer.
"""

import hashlib
import math

import numpy as np
import PIL
import pytest
from PIL import Image, ImageDraw

from teamgym.sim import (
    Box,
    DiffDriveRobot,
    Door,
    Lamp,
    MovingPolygon,
    Overlay,
    Renderer,
    StaticPolygon,
    Target,
    Wall,
    World,
    regular_polygon,
)

PALETTE = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
    (188, 189, 34),
]


def legacy_draw(world, scale, margin, overlay=None):
    """The renderer as it was before the refactor (reference only)."""
    w, h = world.size
    width, height = int(math.ceil((w + 2 * margin) * scale)), int(math.ceil((h + 2 * margin) * scale))
    image = Image.new("RGB", (width, height), (250, 250, 247))
    pen = ImageDraw.Draw(image)

    def px(x, y):
        return ((x + margin) * scale, height - (y + margin) * scale)

    def cross(point, colour, size):
        cx, cy = px(*point)
        s = max(3.0, size * scale)
        pen.line([(cx - s, cy - s), (cx + s, cy + s)], fill=colour, width=2)
        pen.line([(cx - s, cy + s), (cx + s, cy - s)], fill=colour, width=2)

    for e in world.entities.values():
        if isinstance(e, Door):
            colour = (120, 200, 120) if e.is_open else (150, 60, 40)
            line_width = 1 if e.is_open else max(1, int(e.thickness * scale))
            pen.line([px(*e.a), px(*e.b)], fill=colour, width=line_width)
        elif isinstance(e, Wall):
            pen.line([px(*e.a), px(*e.b)], fill=(40, 40, 40), width=max(1, int(e.thickness * scale)))
        elif isinstance(e, StaticPolygon):
            pen.polygon([px(*v) for v in e.vertices], fill=(180, 180, 180), outline=(90, 90, 90))
        elif isinstance(e, (MovingPolygon, Box)):
            verts = [px(*e.body.local_to_world(v)) for v in e.local_vertices]
            fill = (220, 80, 80) if isinstance(e, MovingPolygon) else (205, 170, 110)
            pen.polygon(verts, fill=fill, outline=(60, 30, 30))
        elif isinstance(e, Target):
            cross(e.position, (200, 0, 0), e.radius)
    if overlay is not None:
        for points, colour in overlay.paths:
            if len(points) > 1:
                pen.line([px(*p) for p in points], fill=colour, width=2)
        for point, colour in overlay.points:
            cross(point, colour, 0.03)
        # The old Overlay carried the lamp; it is a Lamp entity now, drawn where the overlay's was.
        for lamp in (e for e in world.entities.values() if isinstance(e, Lamp)):
            lx, ly = px(*lamp.position)
            pen.ellipse([lx - 8, ly - 8, lx + 8, ly + 8], fill=(255, 220, 0), outline=(120, 100, 0))
    index = 0
    for e in world.entities.values():
        if isinstance(e, DiffDriveRobot):
            x, y, theta = e.pose
            r = e.spec.radius * scale
            cx, cy = px(x, y)
            colour = PALETTE[index % len(PALETTE)] if e.enabled else (120, 120, 120)
            pen.ellipse([cx - r, cy - r, cx + r, cy + r], fill=colour, outline=(0, 0, 0))
            pen.line([(cx, cy), (cx + r * math.cos(theta), cy - r * math.sin(theta))], fill=(255, 255, 255), width=2)
            index += 1
    return np.asarray(image)


def mixed_world(steps=0):
    """Every entity kind, ten robots (the palette wraps), one disabled, an open and a closed door."""
    world = World((1.2, 0.8))
    world.add_boundary()
    world.add(Wall("wall", (0.2, 0.1), (0.2, 0.5), 0.012))
    world.add(Door("door_closed", (0.4, 0.1), (0.4, 0.25), 0.01, is_open=False))
    world.add(Door("door_open", (0.4, 0.55), (0.4, 0.7), 0.01, is_open=True))
    world.add(StaticPolygon("table", [(0.9, 0.05), (1.1, 0.05), (1.05, 0.2)]))
    world.add(Box("box", (0.06, 0.04), (0.62, 0.42), 0.05, angle=0.4))
    world.add(Box("heavy", (0.1, 0.1), (0.95, 0.6), 0.5))
    world.add(MovingPolygon("obstacle", regular_polygon(5, 0.05), (0.8, 0.35), (0.1, -0.05)))
    world.add(Target("goal", (0.1, 0.72), radius=0.025))
    robots = []
    for i in range(10):
        angle = 0.7 * i - 2.0
        robots.append(world.add(DiffDriveRobot(f"r{i}", (0.1 + 0.1 * i, 0.05 + 0.07 * (i % 4) + 0.03), angle)))
    robots[3].disable()
    robots[0].teleport((0.55, 0.42), 0.0)  # touching the box
    for _ in range(steps):
        for i, robot in enumerate(robots):
            robot.set_command(0.2, 1.5 * math.sin(i))
        world.step()
    return world


OVERLAY = dict(
    points=[((0.3, 0.3), (255, 0, 0)), ((1.0, 0.7), (0, 128, 0))],
    paths=[([(0.1, 0.1), (0.9, 0.15), (1.1, 0.7)], (0, 0, 255)), ([(0.5, 0.5)], (0, 0, 0))],
)

#: (steps, pixels per metre, margin, overlay?, lamp?) -> SHA-256 of the frame, recorded with
#: the pre-refactor renderer and Pillow ``RECORDED_WITH``.
RECORDED_WITH = "13.0.0"
CASES = {
    (0, 200.0, 0.05, False, False): "3f5c983e572c03677de383914700d88dd74c3cfebe29df02d81ddd3c9c340d93",
    (0, 200.0, 0.05, True, True): "67d7d723d7e73a8f729e45f300a955240c39b35ae63717a8f468c81436a62f44",
    (5, 137.5, 0.1, True, False): "4278043b30cab389dcc6897b14f971c2599367fe056dd692a887cccbcb4a57e0",
    (12, 311.0, 0.0, True, True): "49ad50bbd69e30a386f9f33b90e1e1a0195f699580995145e8c52409d106f526",
}


def frame(case, draw):
    steps, scale, margin, with_overlay, with_lamp = case
    world = mixed_world(steps)
    overlay = None
    if with_overlay:
        overlay = Overlay(**OVERLAY)
        if with_lamp:
            world.add(Lamp("lamp", (1.15, 0.4)))
    return world, draw(world, scale, margin, overlay)


def renderer_draw(world, scale, margin, overlay):
    return Renderer(world, pixels_per_metre=scale, margin=margin).draw(overlay)


@pytest.mark.parametrize("case", list(CASES))
def test_frame_equals_pre_refactor_renderer(case):
    _, expected = frame(case, legacy_draw)
    _, actual = frame(case, renderer_draw)
    np.testing.assert_array_equal(actual, expected)


@pytest.mark.parametrize("case", list(CASES))
def test_frame_matches_recorded_digest(case):
    if PIL.__version__ != RECORDED_WITH:
        pytest.skip(f"digests recorded with Pillow {RECORDED_WITH}, running {PIL.__version__}")
    _, image = frame(case, renderer_draw)
    assert hashlib.sha256(image.tobytes()).hexdigest() == CASES[case]
