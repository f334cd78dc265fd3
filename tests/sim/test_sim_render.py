"""Headless rendering to numpy images, the pygame window in a dummy video driver, GIF export."""

import numpy as np
import pytest
from PIL import Image

from teamgym.sim import (
    Box,
    DiffDriveRobot,
    Door,
    MovingPolygon,
    Overlay,
    Renderer,
    StaticPolygon,
    Target,
    Wall,
    World,
    regular_polygon,
    save_gif,
)
from teamgym.sim.render import robot_colour


@pytest.fixture
def scene():
    world = World((1.0, 0.5))
    world.add_boundary()
    world.add(Wall("wall", (0.2, 0.1), (0.2, 0.4), 0.01))
    world.add(Door("door", (0.4, 0.1), (0.4, 0.2), 0.01, is_open=False))
    world.add(Box("box", (0.05, 0.05), (0.6, 0.4), 0.1))
    world.add(StaticPolygon("table", [(0.8, 0.05), (0.95, 0.05), (0.9, 0.15)]))
    world.add(MovingPolygon("obstacle", regular_polygon(5, 0.04), (0.8, 0.35), (0.0, 0.0)))
    world.add(Target("goal", (0.1, 0.45)))
    robot = world.add(DiffDriveRobot("r", (0.5, 0.25), 0.0))
    return world, robot


def test_draw_returns_uint8_image_of_the_arena(scene):
    world, robot = scene
    renderer = Renderer(world, pixels_per_metre=200, margin=0.05)
    frame = renderer.draw()
    assert frame.dtype == np.uint8
    assert frame.shape == (renderer.height, renderer.width, 3)
    assert abs(renderer.width - 220) <= 1 and abs(renderer.height - 120) <= 1  # (1.0 + 2 * 0.05) m x 200 px/m
    # The robot's body is drawn in its colour at its centre (heading line aside).
    cx, cy = renderer.to_pixels(*robot.position)
    assert tuple(frame[int(cy) + 3, int(cx)]) == robot_colour(0)
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 5


def test_frame_changes_when_robot_moves(scene):
    world, robot = scene
    renderer = Renderer(world)
    before = renderer.draw()
    assert np.array_equal(before, renderer.draw())  # drawing twice is deterministic
    for _ in range(5):
        robot.set_command(0.3, 0.0)
        world.step()
    after = renderer.draw()
    assert after.shape == before.shape
    changed = np.any(after != before, axis=2)
    assert changed.sum() > 50
    cols = np.flatnonzero(changed.any(axis=0))
    lo, hi = renderer.to_pixels(0.5 - 0.03, 0)[0], renderer.to_pixels(0.5 + 0.15 + 0.03, 0)[0]
    assert lo - 2 <= cols.min() and cols.max() <= hi + 2  # only the robot's swept region changed


def test_overlay_is_drawn(scene):
    world, _ = scene
    renderer = Renderer(world)
    plain = renderer.draw()
    overlay = Overlay(points=[((0.3, 0.3), (255, 0, 0))], paths=[([(0.1, 0.1), (0.9, 0.1)], (0, 0, 255))])
    marked = renderer.draw(overlay)
    assert np.any(marked != plain)
    px, py = renderer.to_pixels(0.5, 0.1)
    assert tuple(marked[int(py), int(px)]) == (0, 0, 255)


def test_human_window_is_headless(scene):
    world, _ = scene
    renderer = Renderer(world)
    frame = renderer.draw()
    renderer.show(frame, fps=1000)
    assert renderer._window is not None
    renderer.close()
    assert renderer._window is None


def test_save_gif_writes_multi_frame_gif(scene, tmp_path):
    world, robot = scene
    renderer = Renderer(world)
    frames = []
    for _ in range(4):
        robot.set_command(0.3, 0.5)
        world.step()
        frames.append(renderer.draw())
    path = save_gif(frames, tmp_path / "sub" / "run.gif", fps=5)
    assert path.exists()
    with Image.open(path) as gif:
        assert gif.format == "GIF"
        assert gif.is_animated and gif.n_frames == 4
        assert gif.size == (renderer.width, renderer.height)
        assert gif.info["duration"] == 200
        gif.seek(3)
        last = np.asarray(gif.convert("RGB"))
    assert np.array_equal(last, frames[-1])


def test_save_gif_needs_frames(tmp_path):
    with pytest.raises(ValueError):
        save_gif([], tmp_path / "empty.gif")
