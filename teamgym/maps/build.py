"""Put a map into a simulator :class:`~teamgym.sim.world.World`: walls, doors, furniture."""

from __future__ import annotations

from collections.abc import Mapping

from teamgym.maps.geometry import wall_layout
from teamgym.maps.model import OfficeMap
from teamgym.maps.walls import JoinedWalls
from teamgym.sim.entity import Entity
from teamgym.sim.objects import Door, StaticPolygon, Wall
from teamgym.sim.world import World


def map_entities(
    office: OfficeMap, door_open: Mapping[str, bool] | None = None, furniture: bool = True, join_walls: bool = False
) -> list[Entity]:
    """The map's walls, doors (open or closed per ``door_open``, default open) and furniture, in that order.

    Entity names are the door and furniture ids, and ``wall_<k>`` for walls; with
    ``join_walls`` the walls are one :class:`~teamgym.maps.walls.JoinedWalls` entity named
    ``"walls"`` (the same shapes in the same order, on one static body).
    """
    door_open = dict(door_open or {})
    unknown = sorted(set(door_open) - set(office.door_ids))
    if unknown:
        raise KeyError(f"unknown door(s) {unknown}; map {office.name!r} has {office.door_ids}")
    walls, door_segments = wall_layout(office)
    t = office.wall_thickness
    entities: list[Entity] = [Wall(seg.name, seg.a, seg.b, t) for seg in walls]
    if join_walls and entities:
        entities = [JoinedWalls("walls", entities)]
    entities += [Door(seg.name, seg.a, seg.b, t, is_open=door_open.get(seg.name, True)) for seg in door_segments]
    if furniture:
        entities += [StaticPolygon(f.id, f.vertices) for f in office.furniture]
    return entities


def build_world(
    office: OfficeMap, world: World, door_open: Mapping[str, bool] | None = None, furniture: bool = True
) -> dict[str, Door]:
    """Add the :func:`map_entities` to ``world``; returns the :class:`~teamgym.sim.objects.Door` entities by door id."""
    entities = map_entities(office, door_open, furniture)
    for entity in entities:
        world.add(entity)
    return {e.name: e for e in entities if isinstance(e, Door)}
