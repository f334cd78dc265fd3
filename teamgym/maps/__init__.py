"""Workspaces as data: offices *and* graphs of places and ways.

Office maps (paper 000, section 2.1): sectors, doors, furniture, topology. Graph maps
(paper 003, section 2): places with coordinates joined by ways with lengths.

>>> from teamgym.maps import load_map, TopologicalModel, load_graph_map
>>> office = load_map("office12")
>>> model = TopologicalModel(office)
>>> load_graph_map("square4").shortest_path("A", "C", blocked=[("A", "C")])
['A', 'D', 'C']
"""

from teamgym.maps.abstraction import (
    Workspace,
    cell_decomposition,
    random_grid_map,
    random_voronoi_map,
    random_workspace,
    triangulate_free_space,
    voronoi_roadmap,
)
from teamgym.maps.geometry import Segment, wall_layout
from teamgym.maps.graph import (
    GraphMap,
    NoPathError,
    Place,
    Way,
    available_graph_maps,
    graph_map_from_dict,
    load_graph_map,
    save_graph_map,
    validate_graph_map,
)
from teamgym.maps.model import DoorObject, Furniture, MapError, OfficeMap, Sector, available_maps, load_map, map_from_dict
from teamgym.maps.plot import plot_graph_map
from teamgym.maps.topology import (
    DOOR_READINGS,
    ClutterEstimate,
    TopologicalModel,
    characteristic_distance,
    door_cost,
    passage_cost,
)
from teamgym.maps.validate import validate

__all__ = [
    "DOOR_READINGS",
    "ClutterEstimate",
    "DoorObject",
    "Furniture",
    "GraphMap",
    "MapError",
    "NoPathError",
    "OfficeMap",
    "Place",
    "Sector",
    "Segment",
    "TopologicalModel",
    "Way",
    "Workspace",
    "available_graph_maps",
    "available_maps",
    "cell_decomposition",
    "characteristic_distance",
    "door_cost",
    "graph_map_from_dict",
    "load_graph_map",
    "load_map",
    "map_from_dict",
    "passage_cost",
    "plot_graph_map",
    "random_grid_map",
    "random_voronoi_map",
    "random_workspace",
    "save_graph_map",
    "triangulate_free_space",
    "validate",
    "validate_graph_map",
    "voronoi_roadmap",
    "wall_layout",
]
