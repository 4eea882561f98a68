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
