"""Meshes of surfaces with known answers (for tests, benchmarks and demos)."""

from .core import _native, as_faces, as_vertices


def icosphere(level, radius=1.0):
    """Icosahedron subdivided ``level`` times and projected onto the sphere: (V, F)."""
    return _native.icosphere(int(level), float(radius))


def torus(R, r, nu, nv):
    """Torus with centre-line radius R and tube radius r over an nu x nv grid: (V, F)."""
    return _native.torus(float(R), float(r), int(nu), int(nv))


def grid(nx, ny):
    """Unit square in the z = 0 plane, nx x ny cells, two triangles each: (V, F)."""
    return _native.grid(int(nx), int(ny))


def subdivide_linear(V, F):
    """1-to-4 subdivision with new vertices at edge midpoints: (V, F)."""
    return _native.subdivide_linear(as_vertices(V), as_faces(F))


def loop_subdivide(V, F, levels=1):
    """Loop subdivision (OpenSubdiv), ``levels`` times: (V, F) with 4**levels times the faces."""
    return _native.loop_subdivide(as_vertices(V), as_faces(F), int(levels))


def rounded_cube(n=20, r=0.3, quads=False):
    """Cube [-1, 1]^3 with edges rounded to radius r: an n x n grid per side, corners pushed out
    to the rounding. Returns (V, F) with triangles, or with quads (a list of 4-tuples: the quad
    diagonals are then not mesh edges) when ``quads`` is True. Crest lines: its 12 rounded edges
    are ridges, traced as 6 lines (they join at the corners)."""
    import numpy as np

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
    V = c + r * (V - c) / np.linalg.norm(V - c, axis=1)[:, None]
    return (V, quad_list) if quads else (V, np.array(tris, dtype=np.int32))
