"""Plots of evaluation results (matplotlib, Agg backend, no pyplot global state)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from teamgym.sim.render import robot_colour


def _rgb(index: int) -> tuple[float, float, float]:
    r, g, b = robot_colour(index)
    return r / 255.0, g / 255.0, b / 255.0


def plot_trajectories(
    trajectories: Mapping[str, Sequence[tuple[float, float]]],
    path: str | Path,
    arena: tuple[float, float] | None = None,
    goals: Mapping[str, tuple[float, float]] | None = None,
    title: str | None = None,
    walls: Sequence[tuple[tuple[float, float], tuple[float, float]]] | None = None,
    furniture: Sequence[Sequence[tuple[float, float]]] | None = None,
    objects: Mapping[str, Sequence[tuple[float, float]]] | None = None,
) -> Path:
    """Draw every robot's path of one episode and save it as a PNG at ``path``.

    ``trajectories`` maps agent name to its positions (m); starts are marked with a
    circle, end points with a dot, goals (if given, agent -> ``(x, y)``) with a cross in
    the robot's colour. ``arena`` ``(width, height)`` draws the arena bounds, ``walls``
    (segments) and ``furniture`` (polygons) the static geometry; ``objects`` (name -> positions)
    the paths of moving obstacles or boxes in grey, a hollow square at the start and a filled
    one at the end. Returns the path.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon, Rectangle

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(6, 6), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    goals = goals or {}
    for polygon in furniture or ():
        ax.add_patch(Polygon(polygon, closed=True, facecolor="0.8", edgecolor="0.5"))
    for (x0, y0), (x1, y1) in walls or ():
        ax.plot([x0, x1], [y0, y1], "-", color="0.2", linewidth=2)
    for name, points in (objects or {}).items():
        if len(points) == 0:
            continue
        xs = [p[0] for p in points]
        ys = [p[1] for p in points]
        ax.plot(xs, ys, "--", color="0.45", linewidth=1.2)
        ax.plot(xs[0], ys[0], "s", color="0.45", markersize=7, markerfacecolor="none", markeredgewidth=1.5)
        ax.plot(xs[-1], ys[-1], "s", color="0.45", markersize=7)
        ax.annotate(name, (xs[-1], ys[-1]), textcoords="offset points", xytext=(4, 4), fontsize=7, color="0.3")
    for i, (agent, points) in enumerate(trajectories.items()):
        colour = _rgb(i)
        if len(points) == 0:
            continue
        xs = [p[0] for p in points]
        ys = [p[1] for p in points]
        ax.plot(xs, ys, "-", color=colour, linewidth=1.5, label=agent)
        ax.plot(xs[0], ys[0], "o", color=colour, markersize=8, markerfacecolor="none", markeredgewidth=2)
        ax.plot(xs[-1], ys[-1], ".", color=colour, markersize=8)
        if agent in goals:
            gx, gy = goals[agent]
            ax.plot(gx, gy, "x", color=colour, markersize=10, markeredgewidth=2)
    if arena is not None:
        width, height = arena
        ax.add_patch(Rectangle((0.0, 0.0), width, height, fill=False, edgecolor="black", linewidth=2))
        pad = 0.03 * max(width, height)
        ax.set_xlim(-pad, width + pad)
        ax.set_ylim(-pad, height + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    legend_note = "o start, . end" + (", x goal" if goals else "") + ("; grey: objects, □ start, ■ end" if objects else "")
    ax.set_title(f"{title}\n({legend_note})" if title else f"({legend_note})", fontsize=10)
    if 0 < len(trajectories) <= 12:
        ax.legend(loc="upper right", fontsize=8, framealpha=0.7)
    fig.tight_layout()
    fig.savefig(path, format="png")
    return path
