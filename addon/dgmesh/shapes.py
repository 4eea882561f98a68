"""Meshes of surfaces with known answers (for tests, benchmarks and demos)."""

import numpy as np
import numpy.typing as npt

from .core import _native, as_count, as_faces, as_real, as_vertices


def icosphere(level: int, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Icosahedron subdivided ``level`` times and projected onto the sphere: (V, F)."""
    return _native.icosphere(as_count(level, "level", 0, 10), as_real(radius, "radius", 0.0, lo_open=True))


def torus(R: float, r: float, nu: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """Torus with centre-line radius R and tube radius r over an nu x nv grid: (V, F)."""
    return _native.torus(as_real(R, "R", 0.0, lo_open=True), as_real(r, "r", 0.0, lo_open=True),
                         as_count(nu, "nu", 3), as_count(nv, "nv", 3))


def grid(nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit square in the z = 0 plane, nx x ny cells, two triangles each: (V, F)."""
    return _native.grid(as_count(nx, "nx", 1), as_count(ny, "ny", 1))


def subdivide_linear(V: npt.ArrayLike, F: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """1-to-4 subdivision with new vertices at edge midpoints: (V, F)."""
    V = as_vertices(V)
    return _native.subdivide_linear(V, as_faces(F, n=len(V)))


def loop_subdivide(V: npt.ArrayLike, F: npt.ArrayLike, levels: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Loop subdivision (OpenSubdiv), ``levels`` times: (V, F) with 4**levels times the faces."""
    V = as_vertices(V)
    return _native.loop_subdivide(V, as_faces(F, n=len(V)), as_count(levels, "levels"))


def rounded_cube(n: int = 20, r: float = 0.3,
                 quads: bool = False) -> tuple[np.ndarray, np.ndarray | list[tuple[int, int, int, int]]]:
    """Cube [-1, 1]^3 with edges rounded to radius r: an n x n grid per side, corners pushed out
    to the rounding. Returns (V, F) with triangles, or with quads (a list of 4-tuples: the quad
    diagonals are then not mesh edges) when ``quads`` is True. Crest lines: its 12 rounded edges
    are ridges, traced as 6 lines (they join at the corners)."""
    n = as_count(n, "n", 1)
    r = as_real(r, "r", 0.0, 1.0)
    verts, tris, quad_list, index = [], [], [], {}

    def vid(c):
        if c not in index:
            index[c] = len(verts)
            verts.append([2.0 * x / n - 1 for x in c])
        return index[c]

    for axis in range(3):
        for side in (0, 1):
            for a in range(n):
                for b in range(n):
                    def p(da, db):
                        c = [0, 0, 0]
                        c[axis], c[(axis + 1) % 3], c[(axis + 2) % 3] = side * n, a + da, b + db
                        return vid(tuple(c))
                    v00, v10, v11, v01 = p(0, 0), p(1, 0), p(1, 1), p(0, 1)
                    q = (v00, v10, v11, v01)
                    quad_list.append(q if side else q[::-1])
                    tris += [(v00, v10, v11), (v00, v11, v01)] if side else [(v00, v11, v10), (v00, v01, v11)]
    V = np.array(verts)
    c = np.clip(V, -(1 - r), 1 - r)
    d = np.linalg.norm(V - c, axis=1)[:, None]
    V = c + r * np.divide(V - c, d, out=np.zeros_like(V), where=d > 0)  # r = 0: the sharp cube
    return (V, quad_list) if quads else (V, np.array(tris, dtype=np.int32))
