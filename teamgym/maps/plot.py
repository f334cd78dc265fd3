"""Matplotlib drawing of a map (sectors, walls, doors with their circles, furniture).

Used for the figures in ``docs/exploration.md`` and by the experiment scripts to draw
trajectories over the plan. Coordinates are drawn in millimetres, as in the paper.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from teamgym.maps.geometry import wall_layout
from teamgym.maps.graph import GraphMap, Way
from teamgym.maps.model import OfficeMap


def draw_map(
    office: OfficeMap, ax: Any = None, labels: bool = True, door_circles: bool = True, closed: tuple[str, ...] = ()
) -> Any:
    """Draw ``office`` on a matplotlib axes (created if None) and return the axes.

    Doors in ``closed`` are drawn as closed (dark red), the others as open (green gap).
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon, Rectangle

    if ax is None:
        w, h = office.size
        _, ax = plt.subplots(figsize=(2 + 6 * w / max(w, h), 1 + 6 * h / max(w, h)))
    k = 1000.0
    for s in office.sectors:
        colour = "#eef3fb" if s.kind == "corridor" else "#fbf8ef"
        ax.add_patch(
            Rectangle((s.x_min * k, s.y_min * k), (s.x_max - s.x_min) * k, (s.y_max - s.y_min) * k, color=colour, zorder=0)
        )
        if labels:
            text = s.id if s.kind == "corridor" and s.clutter == 0 else f"{s.id}\nc={s.clutter:g}"
            ax.text(s.centre[0] * k, s.centre[1] * k, text, ha="center", va="center", fontsize=8, color="#335", zorder=5)
    for f in office.furniture:
        ax.add_patch(Polygon([(x * k, y * k) for x, y in f.vertices], closed=True, color="#b5b5b5", ec="#707070", zorder=2))
    walls, doors = wall_layout(office)
    for seg in walls:
        ax.plot([seg.a[0] * k, seg.b[0] * k], [seg.a[1] * k, seg.b[1] * k], color="#222", lw=2.2, solid_capstyle="butt", zorder=3)
    for seg, door in zip(doors, office.doors):
        shut = door.id in closed
        ax.plot(
            [seg.a[0] * k, seg.b[0] * k],
            [seg.a[1] * k, seg.b[1] * k],
            color="#8b2a1a" if shut else "#4caf50",
            lw=2.2 if shut else 1.0,
            ls="-" if shut else ":",
            zorder=3,
        )
        if door_circles:
            ax.add_patch(
                Circle((door.centre[0] * k, door.centre[1] * k), door.radius * k, fill=False, ec="#4caf50", lw=0.6, ls="--")
            )
        if labels:
            tag = door.id if door.open_probability == 1 else f"{door.id}\no={door.open_probability:g}"
            ax.text(door.centre[0] * k, door.centre[1] * k, tag, ha="center", va="center", fontsize=6, color="#1b5e20", zorder=6)
    ax.set_xlim(-20, office.size[0] * k + 20)
    ax.set_ylim(-20, office.size[1] * k + 20)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    return ax


def save_map_figure(office: OfficeMap, path: str | Path, title: str | None = None, closed: tuple[str, ...] = ()) -> Path:
    """Draw ``office`` alone and save it as an image at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = draw_map(office, closed=closed)
    ax.set_title(title or office.name)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ax.figure.tight_layout()
    ax.figure.savefig(path, dpi=130)
    plt.close(ax.figure)
    return path


def plot_graph_map(
    graph_map: GraphMap,
    ax: Any = None,
    blocked: Iterable[Way | tuple[str, str]] = (),
    path: Sequence[str] | None = None,
    labels: bool = True,
) -> Any:
    """Draw a graph map (paper 003) on a matplotlib axes (created if None) and return the axes; metres.

    ``ax.lines`` gains one line per way, in the order of ``graph_map.ways`` (ways in ``blocked``
    dashed red), then one for ``path`` (place ids, each consecutive pair joined by a way) if
    given; places are a scatter of dots labelled with their ids.
    """
    import matplotlib.pyplot as plt

    cut = graph_map.resolve_ways(blocked)
    points = [graph_map.place(pid).pos for pid in path] if path is not None else []
    if path is not None:
        for a, b in zip(path, path[1:]):
            graph_map.way(a, b)
    if ax is None:
        w, h = graph_map.size
        _, ax = plt.subplots(figsize=(1 + 6 * w / max(w, h), 1 + 6 * h / max(w, h)))
    for way in graph_map.ways:
        (xa, ya), (xb, yb) = graph_map.place(way.a).pos, graph_map.place(way.b).pos
        shut = way.ends in cut
        ax.plot([xa, xb], [ya, yb], color="#c62828" if shut else "#607d8b", ls="--" if shut else "-", lw=1.2, zorder=1)
    if path is not None:
        ax.plot([x for x, _ in points], [y for _, y in points], color="#ff9800", lw=3.5, alpha=0.8, zorder=2)
    ax.scatter([p.x for p in graph_map.places], [p.y for p in graph_map.places], s=30, color="#263238", zorder=3)
    if labels:
        for p in graph_map.places:
            ax.annotate(p.id, p.pos, xytext=(4, 4), textcoords="offset points", fontsize=8, color="#263238", zorder=4)
    w, h = graph_map.size
    ax.set_xlim(0, w)
    ax.set_ylim(0, h)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return ax
