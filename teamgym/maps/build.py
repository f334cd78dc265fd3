"""Put a map into a simulator :class:`~teamgym.sim.world.World`: walls, doors, furniture."""

from __future__ import annotations

from collections.abc import Mapping

from teamgym.maps.geometry import wall_layout
from teamgym.maps.model import OfficeMap
from teamgym.sim.objects import Door, StaticPolygon, Wall
from teamgym.sim.world import World


def build_world(
    office: OfficeMap, world: World, door_open: Mapping[str, bool] | None = None, furniture: bool = True
) -> dict[str, Door]:
    """Add the map's walls, doors (open or closed per ``door_open``, default open) and furniture.

    Returns the :class:`~teamgym.sim.objects.Door` entities by door id. Entity names are the
    door and furniture ids, and ``wall_<k>`` for walls.
    """
    door_open = dict(door_open or {})
    unknown = sorted(set(door_open) - set(office.door_ids))
    if unknown:
        raise KeyError(f"unknown door(s) {unknown}; map {office.name!r} has {office.door_ids}")
    walls, door_segments = wall_layout(office)
    t = office.wall_thickness
    for seg in walls:
        world.add(Wall(seg.name, seg.a, seg.b, t))
    doors = {}
    for seg in door_segments:
        doors[seg.name] = world.add(Door(seg.name, seg.a, seg.b, t, is_open=door_open.get(seg.name, True)))
    if furniture:
        for f in office.furniture:
            world.add(StaticPolygon(f.id, f.vertices))
    return doors
