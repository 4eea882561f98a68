"""Where references to vertices a re-triangulation removed go (vertex parents, Hook modifiers:
``bridge.remap_vertex_references`` takes the function made here)."""

from collections.abc import Callable

import numpy as np


def nearest_output(V_out: np.ndarray, ids: np.ndarray, V: np.ndarray,
                   out_index: np.ndarray) -> Callable[[int], int]:
    """Where references to a removed vertex of a region go: the mesh vertex of the output vertex
    nearest to it. ``V_out`` (k, 3): the output vertices, ``out_index`` (k,) their mesh vertices;
    ``ids`` (n,): the region's mesh vertices, ``V`` (n, 3) their positions. Returns
    nearest(old mesh vertex) -> new mesh vertex, for the region's vertices."""
    chart = {int(v): k for k, v in enumerate(ids)}

    def nearest(old):
        return out_index[np.argmin(np.linalg.norm(V_out - V[chart[old]], axis=1))]
    return nearest
