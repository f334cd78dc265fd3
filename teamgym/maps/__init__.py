"""Office workspaces as data (paper 000, section 2.1): sectors, doors, furniture, topology.

>>> from teamgym.maps import load_map, TopologicalModel
>>> office = load_map("office12")
>>> model = TopologicalModel(office)
"""

from teamgym.maps.geometry import Segment, wall_layout
from teamgym.maps.model import DoorObject, Furniture, MapError, OfficeMap, Sector, available_maps, load_map, map_from_dict
from teamgym.maps.topology import ClutterEstimate, TopologicalModel, characteristic_distance, door_cost, passage_cost
from teamgym.maps.validate import validate

__all__ = [
    "ClutterEstimate",
    "DoorObject",
    "Furniture",
    "MapError",
    "OfficeMap",
    "Sector",
    "Segment",
    "TopologicalModel",
    "available_maps",
    "characteristic_distance",
    "door_cost",
    "load_map",
    "map_from_dict",
    "passage_cost",
    "validate",
    "wall_layout",
]
