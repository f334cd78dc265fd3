"""The workspace model of paper 000, section 2.1: rectangular sectors, door objects, furniture.

A map is read from a JSON file (see ``docs/exploration.md`` for the format). Lengths in
the file are in ``units`` (``"mm"`` by default, as in the paper) and are converted to
metres here. Coordinates are teamgym's world frame: x to the right, **y up**. A sector is
given, as in the paper, by its top-left corner ``(x^t, y^t)`` (smallest x, largest y), its
bottom-right corner ``(x^b, y^b)`` and a centre point ``(x^p, y^p)``; a door object by the
centre ``(x^p, y^p)`` and radius ``r_j`` of its circle, plus the width of the physical
opening in the wall. ``clutter`` is c_i of eq. (2), ``open_probability`` is o_j.

Parsing only checks types and shapes; :func:`teamgym.maps.validate.validate` checks the
geometry and the graph (both raise :class:`MapError` naming the culprit).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from teamgym.maps.jsonfile import MapError, finite_number, load_json

Point = tuple[float, float]

UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
_TOP_KEYS = {
    "name",
    "description",
    "units",
    "size",
    "wall_thickness",
    "always_connected",
    "sectors",
    "doors",
    "passages",
    "furniture",
}


@dataclass(frozen=True)
class Sector:
    """A rectangular sector (room or corridor part); lengths in metres."""

    id: str
    kind: str
    x_min: float
    y_min: float
    x_max: float
    y_max: float
    centre: Point
    clutter: float

    @property
    def top_left(self) -> Point:
        return (self.x_min, self.y_max)

    @property
    def bottom_right(self) -> Point:
        return (self.x_max, self.y_min)

    @property
    def area(self) -> float:
        return (self.x_max - self.x_min) * (self.y_max - self.y_min)

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """Whether ``(x, y)`` lies inside the rectangle shrunk by ``margin`` (boundary included)."""
        return self.x_min + margin <= x <= self.x_max - margin and self.y_min + margin <= y <= self.y_max - margin


@dataclass(frozen=True)
class DoorObject:
    """A door object: a circle (centre, radius r_j) over an opening of ``width`` in a wall."""

    id: str
    sectors: tuple[str, str]
    centre: Point
    radius: float
    width: float
    open_probability: float


@dataclass(frozen=True)
class Furniture:
    """A convex piece of furniture inside one sector (vertices in metres, counter-clockwise or not)."""

    id: str
    sector: str
    vertices: tuple[Point, ...]


@dataclass(frozen=True)
class OfficeMap:
    """A workspace: sectors, door objects, open passages between sectors, furniture."""

    name: str
    size: Point
    sectors: tuple[Sector, ...]
    doors: tuple[DoorObject, ...]
    passages: tuple[tuple[str, str], ...] = ()
    furniture: tuple[Furniture, ...] = ()
    wall_thickness: float = 0.01
    always_connected: bool = True
    description: str = ""
    source: str = field(default="<map>", compare=False)

    @property
    def sector_ids(self) -> list[str]:
        return [s.id for s in self.sectors]

    @property
    def door_ids(self) -> list[str]:
        return [d.id for d in self.doors]

    @property
    def vertex_ids(self) -> list[str]:
        """Graph vertices in a fixed order: sectors first, then doors (V = V_S ∪ V_D, eq. 1)."""
        return self.sector_ids + self.door_ids

    def sector(self, sector_id: str) -> Sector:
        for s in self.sectors:
            if s.id == sector_id:
                return s
        raise KeyError(f"map {self.name!r} has no sector {sector_id!r}; sectors are {self.sector_ids}")

    def door(self, door_id: str) -> DoorObject:
        for d in self.doors:
            if d.id == door_id:
                return d
        raise KeyError(f"map {self.name!r} has no door {door_id!r}; doors are {self.door_ids}")

    def sector_at(self, x: float, y: float) -> Sector | None:
        """The sector whose rectangle contains ``(x, y)`` (the first one on a shared edge), or None."""
        for s in self.sectors:
            if s.contains(x, y):
                return s
        return None


# -- parsing --------------------------------------------------------------------------


def _fail(source: str, where: str, message: str) -> MapError:
    return MapError(f"{source}: {where}: {message}")


def _number(source: str, where: str, value: Any) -> float:
    if not finite_number(value):
        raise _fail(source, where, f"expected a finite number, got {value!r}")
    return float(value)


def _point(source: str, where: str, value: Any, scale: float) -> Point:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise _fail(source, where, f"expected [x, y], got {value!r}")
    return (_number(source, where, value[0]) * scale, _number(source, where, value[1]) * scale)


def _text(source: str, where: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(source, where, f"expected a non-empty string, got {value!r}")
    return value


def _keys(source: str, where: str, item: Any, required: set[str], optional: set[str]) -> dict:
    if not isinstance(item, dict):
        raise _fail(source, where, f"expected an object, got {type(item).__name__}")
    missing = sorted(required - set(item))
    if missing:
        raise _fail(source, where, f"missing key(s) {missing}")
    unknown = sorted(set(item) - required - optional)
    if unknown:
        raise _fail(source, where, f"unknown key(s) {unknown}; allowed are {sorted(required | optional)}")
    return item


def _list(source: str, where: str, value: Any) -> list:
    if not isinstance(value, list):
        raise _fail(source, where, f"expected a list, got {type(value).__name__}")
    return value


def _parse_sector(source: str, i: int, item: Any, scale: float) -> Sector:
    where = f"sectors[{i}]"
    item = _keys(source, where, item, {"id", "top_left", "bottom_right", "clutter"}, {"kind", "centre"})
    sid = _text(source, f"{where}.id", item["id"])
    where = f"sector {sid!r}"
    x_t, y_t = _point(source, f"{where}.top_left", item["top_left"], scale)
    x_b, y_b = _point(source, f"{where}.bottom_right", item["bottom_right"], scale)
    if not (x_t < x_b and y_b < y_t):
        raise _fail(
            source,
            where,
            f"top_left {item['top_left']} must be left of and above bottom_right {item['bottom_right']} "
            "(y points up: top_left has the smaller x and the larger y)",
        )
    centre = _point(source, f"{where}.centre", item["centre"], scale) if "centre" in item else ((x_t + x_b) / 2, (y_t + y_b) / 2)
    kind = item.get("kind", "room")
    if kind not in ("room", "corridor"):
        raise _fail(source, f"{where}.kind", f"must be 'room' or 'corridor', got {kind!r}")
    clutter = _number(source, f"{where}.clutter", item["clutter"])
    return Sector(sid, kind, x_t, y_b, x_b, y_t, centre, clutter)


def _parse_door(source: str, i: int, item: Any, scale: float) -> tuple[DoorObject, bool]:
    where = f"doors[{i}]"
    item = _keys(source, where, item, {"id", "centre", "radius", "width"}, {"sectors", "open_probability"})
    did = _text(source, f"{where}.id", item["id"])
    where = f"door {did!r}"
    sectors: tuple[str, str] = ("", "")
    declared = "sectors" in item
    if declared:
        value = item["sectors"]
        if not isinstance(value, list) or len(value) != 2 or not all(isinstance(v, str) for v in value):
            raise _fail(source, f"{where}.sectors", f"expected two sector ids, got {value!r}")
        sectors = (value[0], value[1])
    door = DoorObject(
        did,
        sectors,
        _point(source, f"{where}.centre", item["centre"], scale),
        _number(source, f"{where}.radius", item["radius"]) * scale,
        _number(source, f"{where}.width", item["width"]) * scale,
        _number(source, f"{where}.open_probability", item.get("open_probability", 1.0)),
    )
    return door, declared


def _parse_furniture(source: str, i: int, item: Any, scale: float) -> Furniture:
    where = f"furniture[{i}]"
    item = _keys(source, where, item, {"sector"}, {"id", "rect", "polygon"})
    if ("rect" in item) == ("polygon" in item):
        raise _fail(source, where, "give exactly one of 'rect' [x0, y0, x1, y1] or 'polygon' [[x, y], ...]")
    fid = _text(source, f"{where}.id", item.get("id", f"furniture_{i}"))
    if "rect" in item:
        rect = item["rect"]
        if not isinstance(rect, list) or len(rect) != 4:
            raise _fail(source, f"{where}.rect", f"expected [x0, y0, x1, y1], got {rect!r}")
        x0, y0, x1, y1 = (_number(source, f"{where}.rect", v) * scale for v in rect)
        if not (x0 < x1 and y0 < y1):
            raise _fail(source, f"{where}.rect", f"needs x0 < x1 and y0 < y1, got {rect!r}")
        vertices = ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
    else:
        points = _list(source, f"{where}.polygon", item["polygon"])
        vertices = tuple(_point(source, f"{where}.polygon[{k}]", p, scale) for k, p in enumerate(points))
    return Furniture(fid, _text(source, f"{where}.sector", item["sector"]), vertices)


def _parse_passage(source: str, i: int, item: Any) -> tuple[str, str]:
    if not isinstance(item, list) or len(item) != 2 or not all(isinstance(v, str) for v in item):
        raise _fail(source, f"passages[{i}]", f"expected two sector ids, got {item!r}")
    return (item[0], item[1])


def map_from_dict(data: Any, source: str = "<map>") -> OfficeMap:
    """Build an :class:`OfficeMap` from parsed JSON (``source`` names it in error messages).

    Doors without ``sectors`` get the two sectors whose boundaries their centre lies on;
    the result is checked by :func:`teamgym.maps.validate.validate` before it is returned.
    """
    from teamgym.maps.validate import check_sectors, infer_door_sectors, validate

    data = _keys(source, "top level", data, {"size", "sectors", "doors"}, _TOP_KEYS - {"size", "sectors", "doors"})
    units = data.get("units", "mm")
    if not isinstance(units, str) or units not in UNITS:
        raise _fail(source, "units", f"must be one of {sorted(UNITS)}, got {units!r}")
    scale = UNITS[units]
    size = _point(source, "size", data["size"], scale)
    if not (size[0] > 0 and size[1] > 0):
        raise _fail(source, "size", f"width and height must be > 0, got {data['size']!r}")
    thickness = _number(source, "wall_thickness", data.get("wall_thickness", 10.0 * 1e-3 / scale)) * scale
    connected = data.get("always_connected", True)
    if not isinstance(connected, bool):
        raise _fail(source, "always_connected", f"expected true or false, got {connected!r}")
    sectors = tuple(_parse_sector(source, i, s, scale) for i, s in enumerate(_list(source, "sectors", data["sectors"])))
    parsed = [_parse_door(source, i, d, scale) for i, d in enumerate(_list(source, "doors", data["doors"]))]
    passages = tuple(_parse_passage(source, i, p) for i, p in enumerate(_list(source, "passages", data.get("passages", []))))
    furniture = tuple(
        _parse_furniture(source, i, f, scale) for i, f in enumerate(_list(source, "furniture", data.get("furniture", [])))
    )
    office = OfficeMap(
        name=_text(source, "name", data.get("name", Path(source).stem or "map")),
        size=size,
        sectors=sectors,
        doors=tuple(d for d, _ in parsed),
        passages=passages,
        furniture=furniture,
        wall_thickness=thickness,
        always_connected=connected,
        description=str(data.get("description", "")),
        source=source,
    )
    check_sectors(office)
    office = infer_door_sectors(office, declared=[declared for _, declared in parsed])
    validate(office)
    return office


DATA_DIR = Path(__file__).resolve().parent / "data"


def available_maps() -> list[str]:
    """Names of the maps shipped with teamgym (files in ``teamgym/maps/data``)."""
    return sorted(p.stem for p in DATA_DIR.glob("*.json"))


def load_map(name_or_path: str | Path) -> OfficeMap:
    """Load a shipped map by name (``"office12"``) or any map file by path; raise :class:`MapError` if invalid."""
    path = Path(name_or_path)
    if isinstance(name_or_path, str) and name_or_path in available_maps():
        path = DATA_DIR / f"{name_or_path}.json"
    if not path.is_file():
        raise MapError(f"no map {str(name_or_path)!r}: not a shipped map ({available_maps()}) nor a file")
    source = path.name if path.parent == DATA_DIR else str(path)
    return map_from_dict(load_json(path, source, "map"), source=source)
