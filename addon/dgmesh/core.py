"""The numpy face of the core: mesh I/O, validation, curvature.

Arrays in: V as (n, 3) float64 and F as (m, 3) int32, C-contiguous to avoid a copy (other dtypes
and layouts are converted). Results are the bound C++ structs, their arrays numpy views into them.
Native work runs with the GIL released. Errors are raised as MeshError (a ValueError) and its relatives.
"""

import os
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

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

# A progress callback: callable(fraction in [0, 1]); a falsy result other than None cancels.
Progress = Callable[[float], bool | None]


# The largest coordinate magnitude accepted: the algorithms multiply up to four coordinates
# (squared areas, cross products), which stays within double's range below 1e75.
COORD_MAX = 1e50


def as_vertices(V: npt.ArrayLike, name: str = "V") -> np.ndarray:
    """(n, 3) float64 C-contiguous view or copy of V; a clear error for the wrong shape or finite
    coordinates beyond COORD_MAX (NaN and inf are the native checks', which say where they matter:
    uv_stretch ignores loose vertices, NaN ones included)."""
    if np.iscomplexobj(V):
        raise MeshError(f"{name} must hold real coordinates, got complex numbers")
    try:
        V = np.ascontiguousarray(V, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"{name} must be an (n, 3) array of numbers: {exc}") from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshError(f"{name} must have shape (n, 3), got {V.shape}")
    with np.errstate(invalid="ignore"):
        bad = (np.abs(V) > COORD_MAX) & np.isfinite(V)
    if bad.any():
        i = int(np.flatnonzero(bad.any(1))[0])
        raise MeshError(f"{name}: vertex {i} has a coordinate beyond {COORD_MAX:g}: {V[i].tolist()}")
    return V


def as_faces(F: npt.ArrayLike, name: str = "F", n: int | None = None) -> np.ndarray:
    """(m, 3) int32 C-contiguous view or copy of F; a clear error for the wrong shape or for
    indices out of range (below 0, or at least ``n`` when given)."""
    F = np.asarray(F)
    if F.size == 0:
        F = F.reshape(0, 3).astype(np.int32)  # np.asarray([]) is float64
    if F.ndim != 2 or F.shape[1] != 3:
        raise MeshError(f"{name} must have shape (m, 3) (triangles), got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise MeshError(f"{name} must hold integer vertex indices, got {F.dtype}")
    hi = np.iinfo(np.int32).max if n is None else n - 1
    if F.size and (F.min() < 0 or F.max() > hi):
        f = int(np.flatnonzero(((F < 0) | (F > hi)).any(1))[0])
        bound = "" if n is None else f" (the mesh has {n} vertices)"
        raise MeshError(f"{name}: face {f} refers to vertex {F[f].tolist()}, out of range{bound}")
    return np.ascontiguousarray(F, dtype=np.int32)


def as_mask(mask: npt.ArrayLike | None, n: int, name: str = "mask") -> np.ndarray | None:
    """A selection of n items as an (n,) bool array. Accepted: bool per item; integer indices (an
    index list of any length, n included); per-item flags, that is numbers of length n, non-zero
    = selected (an integer array of length n holding only 0 and 1 is read as flags, as Blender's
    foreach_get of a bool field gives). None stays None."""
    if mask is None:
        return None
    m = np.asarray(mask)
    if m.size == 0 and m.dtype != bool:
        m = m.astype(np.int64).ravel()
    flags = m.dtype == bool or not np.issubdtype(m.dtype, np.integer) or (
        m.shape == (n,) and n > 2 and not np.any((m != 0) & (m != 1)))
    if flags:
        if m.shape != (n,) or not (m.dtype == bool or np.issubdtype(m.dtype, np.number)):
            raise MeshError(f"{name} must be one bool per item ({n},) or a list of indices, got "
                            f"{m.dtype} of shape {m.shape}")
        if m.dtype != bool and not np.all(np.isfinite(m)):
            raise MeshError(f"{name} holds NaN or inf")
        return np.ascontiguousarray(m != 0)
    if m.ndim != 1:
        raise MeshError(f"{name}: a list of indices must be one-dimensional, got shape {m.shape}")
    if m.size and (m.min() < 0 or m.max() >= n):
        raise MeshError(f"{name} has indices out of range [0, {n})")
    b = np.zeros(n, dtype=bool)
    b[m] = True
    return b


INT_MAX = 2**31 - 1  # the native side's int


def _scalar(value: Any) -> Any:
    """numpy scalars and 0-d arrays as the Python number they hold; other values unchanged."""
    if isinstance(value, np.generic) or (isinstance(value, np.ndarray) and value.ndim == 0):
        return value.item()
    return value


def as_count(value: Any, name: str, lo: int = 0, hi: int = INT_MAX) -> int:
    """An integer option as an int in [lo, hi], else a MeshError naming it (beyond a C int,
    pybind11's own TypeError printed the whole call, mesh arrays included). A float with an
    integer value (5000.0) and numpy scalars count too; 2.5, True and NaN do not."""
    value = _scalar(value)
    integral = isinstance(value, int) or (isinstance(value, float) and value.is_integer())
    if isinstance(value, bool) or not integral:
        raise MeshError(f"{name} must be an integer, got {value!r}")
    if not lo <= value <= hi:
        raise MeshError(f"{name} must be in [{lo}, {hi}], got {int(value)}")
    return int(value)


def as_real(value: Any, name: str, lo: float = -np.inf, hi: float = np.inf, lo_open: bool = False) -> float:
    """A real option as a finite float in [lo, hi] ((lo, hi] with ``lo_open``), else a MeshError
    naming it."""
    value = _scalar(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise MeshError(f"{name} must be a finite number, got {value!r}")
    if value < lo or (lo_open and value == lo) or value > hi:
        lo_s = "(" if lo_open else "["
        raise MeshError(f"{name} must be in {lo_s}{lo:g}, {hi:g}], got {value!r}")
    return float(value)


def as_choice(value: Any, enum: type, name: str) -> Any:
    """An enum option given as a member of the native ``enum`` or by its name (any case), else a
    MeshError naming the option and the choices."""
    if isinstance(value, enum):
        return value
    members = enum.__members__
    if isinstance(value, str) and value.lower() in members:
        return members[value.lower()]
    raise MeshError(f"unknown {name} {value!r} (use {', '.join(repr(k) for k in members)})")


def as_flag(value: Any, name: str) -> bool:
    """A yes/no option as a bool: True, False, numpy bools, or the integers 0 and 1; else a
    MeshError naming it (``bool('no')`` would be True)."""
    value = _scalar(value)
    if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
        return bool(value)
    raise MeshError(f"{name} must be True or False, got {value!r}")


def as_option(value: Any, current: Any, name: str) -> Any:
    """``value`` checked and converted for an option field whose current value is ``current``: by
    the field's type, an enum (:func:`as_choice`), a bool (:func:`as_flag`), an int
    (:func:`as_count`, any C int; ranges are the native side's) or a float (:func:`as_real`,
    finite). Other fields (arrays, nested options) are returned as they are."""
    if hasattr(type(current), "__members__"):
        return as_choice(value, type(current), name)
    if isinstance(current, bool):
        return as_flag(value, name)
    if isinstance(current, int):
        return as_count(value, name, -INT_MAX - 1)
    if isinstance(current, float):
        return as_real(value, name)
    return value


def make_options(options: Any, **values: Any) -> Any:
    """Sets fields of a native options object (``_native.DenoiseOptions()``, ...), whose C++
    initialisers are the defaults; None keeps a field's value. Every value goes through
    :func:`as_option` (the one type check of every option: a MeshError naming the field); the
    native side checks the ranges. Returns ``options``."""
    for name, value in values.items():
        if value is None:
            continue
        current = getattr(options, name)
        value = as_option(value, current, name)
        try:
            setattr(options, name, value)
        except TypeError:
            raise MeshError(f"{name} must be {type(current).__name__}, got {value!r}") from None
    return options


def fields(obj: Any) -> dict[str, Any]:
    """The fields of a native options or result object as a dict (in declaration order)."""
    return {name: getattr(obj, name) for name in type(obj).__fields__}


def set_num_threads(n: int) -> None:
    """Threads for the native parallel loops, for the whole process (every thread); 0 means all
    cores."""
    try:
        n = as_count(n, "set_num_threads", 0, 4096)
    except MeshError as exc:
        raise ValueError(f"set_num_threads: a whole number in [0, 4096] (0: all cores), got {n!r}") from exc
    _native.set_num_threads(n)


def num_threads() -> int:
    """Threads the native parallel loops use (see :func:`set_num_threads`)."""
    return _native.num_threads()


def read_mesh(path: str | bytes | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Reads an OBJ, OFF or PLY file: returns (V, F) with polygons fan-triangulated."""
    V, F, _N = _native.read_mesh(os.fsdecode(path))  # str, bytes or path-like
    return V, F


def write_mesh(path: str | bytes | os.PathLike, V: npt.ArrayLike, F: npt.ArrayLike,
               normals: npt.ArrayLike | None = None) -> None:
    """Writes an OBJ, OFF or PLY (binary) file, chosen by the extension."""
    N = None if normals is None else as_vertices(normals, "normals")
    _native.write_mesh(os.fsdecode(path), as_vertices(V), as_faces(F), N)


def validate(V: npt.ArrayLike, F: npt.ArrayLike, allow_loose_vertices: bool = True) -> None:
    """Raises MeshError if (V, F) is not a valid manifold triangle mesh: empty, out-of-range
    indices, NaN/inf coordinates, degenerate or duplicate faces, non-manifold edges or vertices,
    inconsistent orientation (and loose vertices unless allowed)."""
    checks = _native.CHECK_SURFACE
    if not as_flag(allow_loose_vertices, "allow_loose_vertices"):
        checks |= _native.CHECK_NO_LOOSE_VERTICES
    _native.validate(as_vertices(V), as_faces(F), checks)


# Results of the core, bound as the C++ structs are (dgmesh/mesh.h, geometry.h).
Topology = _native.Topology
Curvature = _native.Curvature


def topology(V: npt.ArrayLike, F: npt.ArrayLike) -> Topology:
    """Edges, edge faces, boundary loops and connected components of a valid mesh: a
    :class:`Topology` (``edges`` (E, 2) with v0 < v1, ``face_edges`` (m, 3), ``edge_faces`` (E, 2),
    -1 on the boundary, ``boundary_loops`` (lists of vertices, oriented as the faces),
    ``component`` per vertex and ``n_components``)."""
    return _native.topology(as_vertices(V), as_faces(F))


def curvature(V: npt.ArrayLike, F: npt.ArrayLike) -> Curvature:
    """Discrete curvatures per vertex (thesis 3.1).

    Returns a :class:`Curvature`: ``mean`` H (cotangent Laplace-Beltrami with mixed Voronoi areas,
    positive on a sphere with outward normals), ``gaussian`` K (angle deficit), ``normals`` (Nelson
    Max weights), ``area`` (mixed Voronoi area) and ``laplace`` (the Laplace-Beltrami of the
    position, -2 H N). Boundary vertices take the mean of their interior neighbours; loose vertices
    get 0. Rejects invalid meshes with MeshError.
    """
    return _native.curvature(as_vertices(V), as_faces(F))
