"""Crest lines (``dgmesh.crest_lines``) as the polygon mesh's own edges."""

import numpy as np

from ..crest import RIDGE, VALLEY, CrestLines, snap_to_vertices
from .edges import edge_lookup, find_edges
from .mesh import MeshArrays
from .routing import route_edges


def crest_edges(lines: CrestLines, arrays: MeshArrays) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks over the mesh's own edges (``arrays.edges``) following the ridges and the
    valleys: (ridge, valley).

    Points snap to the nearer end of their edge; consecutive snapped vertices are joined by the
    real (polygon) edge between them, or by a short path of real edges when they are joined by a
    triangulation diagonal of an n-gon or a gap jump.
    """
    E = arrays.edges
    nv = len(arrays.V)
    ridge = np.zeros(len(E), bool)
    valley = np.zeros(len(E), bool)
    if len(lines) == 0 or len(E) == 0:
        return ridge, valley
    pairs, line = snap_to_vertices(lines, arrays.V, arrays.F)
    kind = lines.line_kind[line]
    lookup = edge_lookup(E, nv)
    idx = find_edges(lookup, pairs)
    missing = np.flatnonzero(idx < 0)
    if missing.size:
        routed, owner = route_edges(pairs[missing], E, lookup)
        idx = np.concatenate([idx, routed])
        kind = np.concatenate([kind, kind[missing[owner]]])
    ridge[idx[(idx >= 0) & (kind == RIDGE)]] = True
    valley[idx[(idx >= 0) & (kind == VALLEY)]] = True
    return ridge, valley
