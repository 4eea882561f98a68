"""The triangulated polygon mesh the add-on works on, and index ranges over its polygons' loops."""

from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass
class MeshArrays:
    """A polygon mesh as triangles that remember their polygon and corners (loops): what the
    native library takes, plus what writing results back to the polygons needs."""

    V: np.ndarray  # (n, 3) float64 vertex positions (object space)
    F: np.ndarray  # (m, 3) int32 vertex indices of each triangle
    tri_loops: np.ndarray  # (m, 3) int32 loop (face corner) indices of each triangle
    tri_poly: np.ndarray  # (m,) int32 polygon each triangle comes from
    edges: Optional[np.ndarray] = None  # (e, 2) int32 the mesh's own edges, only when asked for

    @property
    def num_vertices(self) -> int:
        return len(self.V)


def ranges(start, count) -> np.ndarray:
    """The concatenated index ranges [start[i], start[i] + count[i]) (e.g. the loops of polygons
    from their loop_start and loop_total), without a Python loop."""
    start, count = np.asarray(start), np.asarray(count)
    return np.repeat(start - np.cumsum(count) + count, count) + np.arange(count.sum())
