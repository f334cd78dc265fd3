"""Graph maps (paper 003, section 2): places with coordinates joined by ways with lengths.

A :class:`GraphMap` abstracts a workspace into a finite graph: a *place* is a region where a
robot can be (a point ``(x, y)`` in metres, in teamgym's world frame, y up) and a *way* is a
route a robot can follow between two places. A way's ``length`` (m) defaults to the straight
line between its places and may not be shorter than it; its optional ``width`` (m) is the
corridor's width. Ways are undirected. The workspace is the rectangle ``[0, w] × [0, h]``
(as for office maps); if the file gives no ``size`` it is the smallest one holding every
place with :data:`SIZE_MARGIN` to spare on the right and at the top.

A map is read from JSON (lengths in metres)::

    {"name": "square4", "size": [3, 3],
     "places": [{"id": "A", "x": 0.5, "y": 0.5}, {"id": "B", "x": 2.5, "y": 0.5}],
     "ways": [{"a": "A", "b": "B", "width": 0.4}]}

Optional top-level keys: ``description``, ``size`` and ``allow_disconnected`` (default
false: every place must be reachable from every other). Constructing a :class:`GraphMap`
directly does not check it; :func:`graph_map_from_dict` and :func:`load_graph_map` run
:func:`validate_graph_map`, which raises :class:`~teamgym.maps.model.MapError` naming the
map's source and the offending item. :func:`teamgym.maps.plot.plot_graph_map` draws a map.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import networkx as nx

from teamgym.maps.jsonfile import MapError, finite_number, load_json

GRAPH_DIR = Path(__file__).resolve().parent / "data" / "graphs"
SIZE_MARGIN = 0.5
"""Space (m) left beyond the largest x and y of the places when a map gives no ``size``."""
LENGTH_TOLERANCE = 1e-9
"""A way may be shorter than the straight line by this much (relative, at least 1e-9 m)."""

_TOP_KEYS = {"name", "description", "size", "allow_disconnected", "places", "ways"}
_PLACE_KEYS = {"id", "x", "y"}
_WAY_KEYS = {"a", "b", "length", "width"}


class NoPathError(nx.NetworkXNoPath, ValueError):
    """No path joins two places of a graph map (with the given ways blocked)."""


@dataclass(frozen=True)
class Place:
    """A place: a location a robot can occupy, at ``(x, y)`` metres."""

    id: str
    x: float
    y: float

    @property
    def pos(self) -> tuple[float, float]:
        return (self.x, self.y)


@dataclass(frozen=True)
class Way:
    """An undirected way between places ``a`` and ``b``; ``length`` and ``width`` in metres.

    A :class:`GraphMap` replaces a ``length`` of None by the straight-line distance.
    """

    a: str
    b: str
    length: float | None = None
    width: float | None = None

    @property
    def ends(self) -> frozenset[str]:
        return frozenset((self.a, self.b))


@dataclass(frozen=True)
class GraphMap:
    """A workspace as a graph of places and ways (paper 003, section 2)."""

    name: str
    places: tuple[Place, ...]
    ways: tuple[Way, ...]
    size: tuple[float, float] | None = None
    allow_disconnected: bool = False
    description: str = ""
    source: str = field(default="<graph map>", compare=False)

    def __post_init__(self) -> None:
        places = tuple(self.places)
        coords = {p.id: p.pos for p in places if finite_number(p.x) and finite_number(p.y)}
        ways = tuple(_with_length(w, coords) for w in self.ways)
        object.__setattr__(self, "places", places)
        object.__setattr__(self, "ways", ways)
        if self.size is None:
            object.__setattr__(self, "size", derived_size(places))
        else:
            object.__setattr__(self, "size", tuple(self.size))

    @property
    def place_ids(self) -> list[str]:
        return [p.id for p in self.places]

    @cached_property
    def _places(self) -> dict[str, Place]:
        return {p.id: p for p in self.places}

    @cached_property
    def _ways(self) -> dict[frozenset[str], Way]:
        return {w.ends: w for w in self.ways}

    @cached_property
    def _graph(self) -> nx.Graph:
        return self.to_networkx()

    def place(self, place_id: str) -> Place:
        """The place called ``place_id`` (KeyError naming the map if there is none)."""
        try:
            return self._places[place_id]
        except (KeyError, TypeError):
            raise KeyError(f"graph map {self.name!r} has no place {place_id!r}; places are {self.place_ids}") from None

    def neighbours(self, place_id: str) -> list[str]:
        """Ids of the places one way away from ``place_id``, in the order of the ways."""
        self.place(place_id)
        return list(self._graph.neighbors(place_id))

    def way(self, a: str, b: str) -> Way:
        """The way joining ``a`` and ``b`` (either order; returned as declared), or KeyError."""
        try:
            return self._ways[frozenset((a, b))]
        except (KeyError, TypeError):
            raise KeyError(f"graph map {self.name!r} has no way between {a!r} and {b!r}") from None

    def to_networkx(self) -> nx.Graph:
        """A new undirected graph: nodes carry ``pos``; edges ``length``, ``weight`` (= length), ``width``."""
        graph = nx.Graph(name=self.name)
        for p in self.places:
            graph.add_node(p.id, pos=p.pos)
        for w in self.ways:
            graph.add_edge(w.a, w.b, length=w.length, weight=w.length, width=w.width)
        return graph

    def shortest_path(self, a: str, b: str, blocked: Iterable[Way | tuple[str, str]] = ()) -> list[str]:
        """Place ids of a shortest path from ``a`` to ``b`` (Dijkstra on lengths), ways in ``blocked`` removed.

        Raises :class:`NoPathError` naming both places if ``b`` cannot be reached.
        """
        return self._dijkstra(a, b, blocked)[1]

    def shortest_path_length(self, a: str, b: str, blocked: Iterable[Way | tuple[str, str]] = ()) -> float:
        """Length (m) of :meth:`shortest_path`."""
        return self._dijkstra(a, b, blocked)[0]

    def _dijkstra(self, a: str, b: str, blocked: Iterable[Way | tuple[str, str]]) -> tuple[float, list[str]]:
        self.place(a)
        self.place(b)
        cut = self.resolve_ways(blocked)

        def length(u: str, v: str, data: dict) -> float | None:
            return None if frozenset((u, v)) in cut else data["length"]  # None hides the edge

        try:
            distance, path = nx.single_source_dijkstra(self._graph, a, b, weight=length)
        except nx.NetworkXNoPath:
            cause = f" with way(s) {sorted(sorted(w) for w in cut)} blocked" if cut else ""
            raise NoPathError(f"graph map {self.name!r}: no path from {a!r} to {b!r}{cause}") from None
        return float(distance), path

    def resolve_ways(self, ways: Iterable[Way | tuple[str, str]]) -> set[frozenset[str]]:
        """The ends ``{a, b}`` of each of ``ways`` (Way objects or (a, b) pairs); KeyError for a pair that is no way."""
        cut = set()
        for item in ways:
            if isinstance(item, Way):
                item = (item.a, item.b)
            if not isinstance(item, (tuple, list)) or len(item) != 2:
                raise TypeError(f"a blocked way must be a Way or a pair of place ids (a, b), got {item!r}")
            cut.add(self.way(*item).ends)
        return cut

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; a ``length`` or ``size`` equal to its default is left out."""
        data: dict[str, Any] = {"name": self.name}
        if self.description:
            data["description"] = self.description
        if self.size != derived_size(self.places):
            data["size"] = [float(v) for v in self.size]
        if self.allow_disconnected:
            data["allow_disconnected"] = True
        data["places"] = [{"id": p.id, "x": float(p.x), "y": float(p.y)} for p in self.places]
        data["ways"] = [self._way_dict(w) for w in self.ways]
        return data

    def _way_dict(self, way: Way) -> dict[str, Any]:
        item: dict[str, Any] = {"a": way.a, "b": way.b}
        if way.length != _straight(self.place(way.a), self.place(way.b)):
            item["length"] = float(way.length)
        if way.width is not None:
            item["width"] = float(way.width)
        return item


def _straight(p: Place, q: Place) -> float:
    return math.hypot(p.x - q.x, p.y - q.y)


def _with_length(way: Way, coords: dict[str, tuple[float, float]]) -> Way:
    if way.length is not None or way.a not in coords or way.b not in coords:
        return way
    (xa, ya), (xb, yb) = coords[way.a], coords[way.b]
    return dataclasses.replace(way, length=math.hypot(xa - xb, ya - yb))


def derived_size(places: Iterable[Place]) -> tuple[float, float]:
    """Workspace ``(w, h)`` for a map without ``size``: largest x and y of the places plus :data:`SIZE_MARGIN`."""
    places = [p for p in places if finite_number(p.x) and finite_number(p.y)]
    width = max((float(p.x) for p in places), default=0.0) + SIZE_MARGIN
    height = max((float(p.y) for p in places), default=0.0) + SIZE_MARGIN
    return (width, height)


# -- validation --------------------------------------------------------------------------


def validate_graph_map(graph_map: GraphMap) -> GraphMap:
    """Check ``graph_map``; return it unchanged or raise :class:`MapError` naming the problem."""
    src = graph_map.source
    if not isinstance(graph_map.name, str) or not graph_map.name:
        raise MapError(f"{src}: name: expected a non-empty string, got {graph_map.name!r}")
    _check_size(graph_map)
    _check_places(graph_map)
    seen: set[frozenset[str]] = set()
    for way in graph_map.ways:
        _check_way(graph_map, way, seen)
    if not graph_map.allow_disconnected:
        _check_connected(graph_map)
    return graph_map


def _check_size(graph_map: GraphMap) -> None:
    size = graph_map.size
    if not (isinstance(size, tuple) and len(size) == 2 and all(finite_number(v) and v > 0 for v in size)):
        raise MapError(f"{graph_map.source}: size: expected [width, height] with finite values > 0, got {size!r}")


def _check_places(graph_map: GraphMap) -> None:
    src = graph_map.source
    if not graph_map.places:
        raise MapError(f"{src}: a graph map needs at least one place")
    w, h = graph_map.size
    for i, p in enumerate(graph_map.places):
        if not isinstance(p.id, str) or not p.id:
            raise MapError(f"{src}: places[{i}].id: expected a non-empty string, got {p.id!r}")
        for axis in ("x", "y"):
            if not finite_number(getattr(p, axis)):
                raise MapError(f"{src}: place {p.id!r}: {axis}={getattr(p, axis)!r} is not a finite number")
        if not (0.0 <= p.x <= w and 0.0 <= p.y <= h):
            raise MapError(f"{src}: place {p.id!r} at ({p.x:g}, {p.y:g}) m lies outside the {w:g} x {h:g} m workspace")
    ids = graph_map.place_ids
    duplicates = sorted(i for i, n in Counter(ids).items() if n > 1)
    if duplicates:
        raise MapError(f"{src}: duplicate place id(s) {duplicates}")


def _check_way(graph_map: GraphMap, way: Way, seen: set[frozenset[str]]) -> None:
    where = f"{graph_map.source}: way [{way.a!r}, {way.b!r}]"
    for end in (way.a, way.b):
        if not isinstance(end, str) or end not in graph_map._places:
            raise MapError(f"{where}: unknown place {end!r}; places are {graph_map.place_ids}")
    if way.a == way.b:
        raise MapError(f"{where} joins place {way.a!r} to itself")
    if way.ends in seen:
        raise MapError(f"{where} is repeated (ways are undirected: [a, b] and [b, a] are the same way)")
    seen.add(way.ends)
    if not (finite_number(way.length) and way.length > 0):
        raise MapError(f"{where}: length must be a finite number > 0, got {way.length!r}")
    straight = _straight(graph_map.place(way.a), graph_map.place(way.b))
    if way.length < straight - LENGTH_TOLERANCE * max(1.0, straight):
        raise MapError(
            f"{where}: length {way.length:.9g} m is shorter than the straight line ({straight:.9g} m) between its places"
        )
    if way.width is not None and not (finite_number(way.width) and way.width > 0):
        raise MapError(f"{where}: width must be a finite number > 0, got {way.width!r}")


def _check_connected(graph_map: GraphMap) -> None:
    parts = sorted((sorted(c) for c in nx.connected_components(graph_map.to_networkx())), key=lambda c: (-len(c), c))
    if len(parts) > 1:
        stranded = [p for part in parts[1:] for p in part]
        raise MapError(
            f"{graph_map.source}: the graph is disconnected: place(s) {stranded} cannot be reached from "
            f'{parts[0][0]!r} (set "allow_disconnected": true to allow this)'
        )


# -- parsing and files -------------------------------------------------------------------


def _fail(source: str, where: str, message: str) -> MapError:
    return MapError(f"{source}: {where}: {message}")


def _object(source: str, where: str, item: Any, required: set[str], optional: set[str]) -> dict:
    if not isinstance(item, dict):
        raise _fail(source, where, f"expected an object, got {type(item).__name__}")
    missing = sorted(required - set(item))
    if missing:
        raise _fail(source, where, f"missing key(s) {missing}")
    unknown = sorted(set(item) - required - optional, key=str)
    if unknown:
        raise _fail(source, where, f"unknown key(s) {unknown}; allowed are {sorted(required | optional)}")
    return item


def _number(source: str, where: str, value: Any) -> float:
    if not finite_number(value):
        raise _fail(source, where, f"expected a finite number, got {value!r}")
    return float(value)


def _text(source: str, where: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(source, where, f"expected a non-empty string, got {value!r}")
    return value


def _list(source: str, where: str, value: Any) -> list:
    if not isinstance(value, list):
        raise _fail(source, where, f"expected a list, got {type(value).__name__}")
    return value


def _parse_place(source: str, i: int, item: Any) -> Place:
    item = _object(source, f"places[{i}]", item, _PLACE_KEYS, set())
    pid = _text(source, f"places[{i}].id", item["id"])
    return Place(pid, _number(source, f"place {pid!r}.x", item["x"]), _number(source, f"place {pid!r}.y", item["y"]))


def _parse_way(source: str, i: int, item: Any) -> Way:
    item = _object(source, f"ways[{i}]", item, {"a", "b"}, _WAY_KEYS - {"a", "b"})
    a = _text(source, f"ways[{i}].a", item["a"])
    b = _text(source, f"ways[{i}].b", item["b"])
    where = f"way [{a!r}, {b!r}]"
    length = _number(source, f"{where}.length", item["length"]) if "length" in item else None
    width = _number(source, f"{where}.width", item["width"]) if "width" in item else None
    return Way(a, b, length, width)


def _parse_size(source: str, value: Any) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise _fail(source, "size", f"expected [width, height], got {value!r}")
    return (_number(source, "size", value[0]), _number(source, "size", value[1]))


def graph_map_from_dict(data: Any, source: str = "<graph map>") -> GraphMap:
    """Build and validate a :class:`GraphMap` from parsed JSON (``source`` names it in error messages)."""
    data = _object(source, "top level", data, {"places"}, _TOP_KEYS - {"places"})
    allow = data.get("allow_disconnected", False)
    if not isinstance(allow, bool):
        raise _fail(source, "allow_disconnected", f"expected true or false, got {allow!r}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise _fail(source, "description", f"expected a string, got {description!r}")
    graph_map = GraphMap(
        name=_text(source, "name", data.get("name", Path(source).stem or "graph")),
        places=tuple(_parse_place(source, i, p) for i, p in enumerate(_list(source, "places", data["places"]))),
        ways=tuple(_parse_way(source, i, w) for i, w in enumerate(_list(source, "ways", data.get("ways", [])))),
        size=_parse_size(source, data["size"]) if "size" in data else None,
        allow_disconnected=allow,
        description=description,
        source=source,
    )
    return validate_graph_map(graph_map)


def available_graph_maps() -> list[str]:
    """Names of the graph maps shipped with teamgym (files in ``teamgym/maps/data/graphs``)."""
    return sorted(p.stem for p in GRAPH_DIR.glob("*.json"))


def load_graph_map(name_or_path: str | Path) -> GraphMap:
    """Load a shipped graph map by name (``"square4"``) or a JSON file by path; raise :class:`MapError` if invalid."""
    path = Path(name_or_path)
    if isinstance(name_or_path, str) and name_or_path in available_graph_maps():
        path = GRAPH_DIR / f"{name_or_path}.json"
    if not path.is_file():
        raise MapError(f"no graph map {str(name_or_path)!r}: not a shipped graph map ({available_graph_maps()}) nor a file")
    source = path.name if path.parent == GRAPH_DIR else str(path)
    return graph_map_from_dict(load_json(path, source, "graph map"), source=source)


def save_graph_map(graph_map: GraphMap, path: str | Path) -> Path:
    """Validate ``graph_map`` and write it as JSON to ``path`` (parent folders created); return the path."""
    validate_graph_map(graph_map)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(graph_map.to_dict(), indent=2) + "\n")
    return path
