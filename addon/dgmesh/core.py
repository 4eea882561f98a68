"""The numpy face of the core: mesh I/O, validation, curvature.

Arrays in: V as (n, 3) float64 and F as (m, 3) int32, C-contiguous to avoid a copy (other dtypes
and layouts are converted). Arrays out are fresh numpy arrays. Native work runs with the GIL
released. Errors are raised as MeshError (a ValueError) and its relatives.
"""

import os

import numpy as np

try:
    from . import _native
except ImportError as exc:  # pragma: no cover - only without a build
    import glob
    import sys

    built = [os.path.basename(p) for p in glob.glob(os.path.join(os.path.dirname(__file__), "_native*.so"))]
    # Blender 4.0 runs Python 3.10; the module is built for one Python (3.11 on Debian bookworm)
    # and links Debian's OpenSubdiv, UMFPACK and Qhull, which must be installed.
    raise ImportError(
        "dgmesh's compiled module could not be loaded in Python "
        f"{sys.version_info.major}.{sys.version_info.minor}: "
        + (f"found {', '.join(built)}, " if built else "none is built; ")
        + "build it for this Python with `bash scripts/build.sh` (it installs the libraries it "
        f"links: libosd, libumfpack, libqhull). Original error: {exc}"
    ) from exc

Error = _native.Error
MeshError = _native.MeshError
MeshIOError = _native.MeshIOError
SolverError = _native.SolverError
Cancelled = _native.Cancelled


def as_vertices(V, name="V"):
    """(n, 3) float64 C-contiguous view or copy of V; a clear error for the wrong shape."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshError(f"{name} must have shape (n, 3), got {V.shape}")
    return V


def as_faces(F, name="F"):
    """(m, 3) int32 C-contiguous view or copy of F; a clear error for the wrong shape or range."""
    F = np.asarray(F)
    if F.size == 0:
        F = F.reshape(0, 3)
    if F.ndim != 2 or F.shape[1] != 3:
        raise MeshError(f"{name} must have shape (m, 3) (triangles), got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise MeshError(f"{name} must hold integer vertex indices, got {F.dtype}")
    if F.size and (F.min() < 0 or F.max() > np.iinfo(np.int32).max):
        raise MeshError(f"{name} has vertex indices out of range")
    return np.ascontiguousarray(F, dtype=np.int32)


INT_MAX = 2**31 - 1  # the native side's int


def as_count(value, name, lo=0, hi=INT_MAX, floats=True):
    """An integer option as an int in [lo, hi], else a MeshError naming it (beyond a C int,
    pybind11's own TypeError printed the whole call, mesh arrays included). ``floats``: a float
    with an integer value (5000.0) is accepted too."""
    integral = isinstance(value, (int, np.integer)) or (floats and isinstance(value, float) and value.is_integer())
    if isinstance(value, bool) or not integral:
        raise MeshError(f"{name} must be an integer, got {value!r}")
    if not lo <= value <= hi:
        raise MeshError(f"{name} must be in [{lo}, {hi}], got {int(value)}")
    return int(value)


def set_num_threads(n):
    """Threads for the native parallel loops, for the whole process (every thread); 0 means all
    cores."""
    try:
        n = as_count(n, "set_num_threads", 0, 4096)
    except MeshError as exc:
        raise ValueError(f"set_num_threads: a whole number in [0, 4096] (0: all cores), got {n!r}") from exc
    _native.set_num_threads(n)


def num_threads():
    return _native.num_threads()


def read_mesh(path):
    """Reads an OBJ, OFF or PLY file: returns (V, F) with polygons fan-triangulated."""
    V, F, _N = _native.read_mesh(os.fsdecode(path))  # str, bytes or path-like
    return V, F


def write_mesh(path, V, F, normals=None):
    """Writes an OBJ, OFF or PLY (binary) file, chosen by the extension."""
    N = None if normals is None else as_vertices(normals, "normals")
    _native.write_mesh(os.fsdecode(path), as_vertices(V), as_faces(F), N)


def validate(V, F, allow_loose_vertices=True):
    """Raises MeshError if (V, F) is not a valid manifold triangle mesh: empty, out-of-range
    indices, NaN/inf coordinates, degenerate or duplicate faces, non-manifold edges or vertices,
    inconsistent orientation (and loose vertices unless allowed)."""
    checks = _native.CHECK_SURFACE
    if not allow_loose_vertices:
        checks |= _native.CHECK_NO_LOOSE_VERTICES
    _native.validate(as_vertices(V), as_faces(F), checks)


def topology(V, F):
    """Edges, edge faces, boundary loops and connected components of a valid mesh."""
    return _native.topology(as_vertices(V), as_faces(F))


def curvature(V, F):
    """Discrete curvatures per vertex (thesis 3.1).

    Returns a dict: ``mean`` H (cotangent Laplace-Beltrami with mixed Voronoi areas, positive on a
    sphere with outward normals), ``gaussian`` K (angle deficit), ``normals`` (Nelson Max weights)
    and ``area`` (mixed Voronoi area). Boundary vertices take the mean of their interior
    neighbours; loose vertices get 0. Rejects invalid meshes with MeshError.
    """
    return _native.curvature(as_vertices(V), as_faces(F))
