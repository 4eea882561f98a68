"""Polygon-mesh work of the Blender add-on, in plain numpy (no bpy): what the operators do to the
arrays ``blender/bridge.py`` reads, between reading and writing, so it can be tested without
Blender. One purpose per module:

* ``mesh``: :class:`MeshArrays` (a polygon mesh as triangles that remember their polygon and
  loops), :func:`ranges` (the loops of polygons);
* ``edges``: the one edge key and edge lookup (:func:`edge_keys`, :func:`edge_lookup`,
  :func:`find_edges`);
* ``routing``: shortest edge paths between vertex pairs (:func:`route_edges`);
* ``triangulation``: n-gon triangle repair (:func:`repair_ngon_triangles`), region orientation
  (:func:`orient_region`);
* ``mirror``: half meshes closed by mirror planes (:func:`flip_off_mirror_planes`,
  :func:`mirrored`);
* ``charts``: seam charts of polygons (:func:`split_charts`);
* ``attributes``: data of new elements blended from their sources (:func:`blend_attributes`,
  :func:`nearest_sources`);
* ``decimation``: a mesh's data carried onto its decimated triangles (:func:`corner_plan`,
  :func:`moved_vertex_lookup`, ...);
* ``corners``: corner values of a re-triangulated region (:func:`island_corners`) and of triangles
  that replace polygons (:func:`interpolate_corners`, :func:`corner_weights`);
* ``measures``: numbers reported about a result (:func:`moved_count`, :func:`min_angle_deg`);
* ``references``: where references to removed vertices go (:func:`nearest_output`);
* ``lines``: crest lines as the mesh's own edges (:func:`crest_edges`).
"""

from .attributes import blend_attributes, blend_group_weights, nearest_sources
from .charts import split_charts
from .corners import corner_weights, interpolate_corners, island_corners, shared_edges
from .decimation import (corner_plan, decimated_corner_values, largest_source_values, locked_vertices,
                         moved_vertex_lookup, moved_vertex_values, surviving_edges, transfer_corner_values,
                         vertex_sources, wire_edges)
from .edges import EdgeLookup, edge_key, edge_keys, edge_lookup, face_edge_keys, find_edges, half_edge_keys
from .lines import crest_edges
from .measures import min_angle_deg, moved_count
from .mesh import MeshArrays, ranges
from .mirror import flip_off_mirror_planes, mirror_plane_bits, mirrored, on_mirror_planes, split_seam_edges
from .references import nearest_output
from .routing import adjacency, route, route_edges
from .triangulation import orient_region, repair_ngon_triangles, unfold_ngon_triangles

__all__ = [
    "blend_attributes", "blend_group_weights", "nearest_sources",
    "split_charts",
    "corner_weights", "interpolate_corners", "island_corners", "shared_edges",
    "corner_plan", "decimated_corner_values", "largest_source_values", "locked_vertices", "moved_vertex_lookup",
    "moved_vertex_values", "surviving_edges", "transfer_corner_values", "vertex_sources", "wire_edges",
    "EdgeLookup", "edge_key", "edge_keys", "edge_lookup", "face_edge_keys", "find_edges", "half_edge_keys",
    "crest_edges",
    "min_angle_deg", "moved_count",
    "MeshArrays", "ranges",
    "flip_off_mirror_planes", "mirror_plane_bits", "mirrored", "on_mirror_planes", "split_seam_edges",
    "nearest_output",
    "adjacency", "route", "route_edges",
    "orient_region", "repair_ngon_triangles", "unfold_ngon_triangles",
]
