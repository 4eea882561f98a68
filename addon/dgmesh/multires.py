"""Displaced-subdivision multiresolution layer (thesis 6.4 and the end of 6.5, after Lee, Moreton
and Hoppe 2000, "Displaced subdivision surfaces").

A dense mesh is represented by a coarse control mesh (quadric decimation of the dense mesh, manifold
and topology preserving, with a sliver guard), the Loop limit surface of that control mesh
(OpenSubdiv), and per dense vertex a base point on the limit surface -- a control face and (s, t) in
it -- with a displacement (a, b, c) in the limit surface's local frame there::

    x = S(f, s, t) + a t1 + b t2 + c n,   t1 = S_s / |S_s|,  n = S_s x S_t / |S_s x S_t|,  t2 = n x t1

c is the scalar displacement of DSS along the limit normal; (a, b) is the small tangential residual
left because the base point is a numerically found closest point, so the rest pose reconstructs
exactly. The dense mesh keeps its own topology (only its vertex positions are bound), so UVs,
vertex groups and other data stay valid.

Deforming the control mesh (a few thousand triangles) and calling :meth:`Multires.reconstruct`
moves the dense mesh: one parallel sparse product over the control vertices through precomputed
stencils (limit position and tangents), then the frame and the displacement. A rigid motion of the
control mesh moves the dense mesh rigidly.

Beyond the thesis's simplified DSS, :meth:`Multires.build` fits the control vertices by least
squares so that the limit surface passes close to the dense mesh (the optimisation step of
[LMH00]), which makes the displacements smaller and the deformations follow the control mesh
better; ``fit_iterations=0`` keeps the decimated positions.
"""

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from .core import INT_MAX, MeshError, Progress, _native, as_count, as_faces, as_vertices, make_options

__all__ = ["Multires", "MultiresOptions", "MultiresTimings", "FORMAT_VERSION"]

# The build options and timings are the C++ structs (dgmesh/multires.h), bound as they are.
MultiresOptions = _native.MultiresOptions
MultiresTimings = _native.MultiresTimings
_D = MultiresOptions()

FORMAT_VERSION = 1
_KEYS = ("control_vertices", "control_faces", "level", "base_face", "base_st", "displacement")


def _single(value: Any) -> Any:
    """A saved single value (a 0-d or 1-element array) as a 0-d array; other shapes unchanged."""
    v = np.asarray(value)
    return v.reshape(()) if v.size == 1 else v


class Multires:
    """A dense mesh bound to the Loop limit surface of a coarse control mesh.

    Create one with :meth:`build` (decimates the dense mesh), :meth:`bind` (your own control mesh)
    or :meth:`from_arrays` / :meth:`load` (saved bind data). Instances are immutable and cheap to
    share; every array property returns a fresh copy.
    """

    def __init__(self, native: _native.Multires) -> None:
        self._m = native

    # -- construction ---------------------------------------------------------------------------
    @classmethod
    def build(cls, V: npt.ArrayLike, F: npt.ArrayLike, *, control_faces: int = _D.control_faces, level: int = _D.level,
              min_quality: float = _D.min_quality, fit_iterations: int = _D.fit_iterations,
              fit_regularization: float = _D.fit_regularization,
              projection_iterations: int = _D.projection_iterations,
              progress: Progress | None = None) -> "Multires":
        """Builds the control mesh of (V, F) and binds every vertex of V. The defaults are
        :class:`MultiresOptions`'s (dgmesh/multires.h).

        Parameters
        ----------
        V, F : the dense triangle mesh; it must be manifold with no degenerate faces (MeshError
            otherwise). Loose vertices are bound too.
        control_faces : target face count of the control mesh (decimation may stop a little above
            it when the sliver guard or the topology forbid further collapses; every connected
            component keeps at least a tetrahedron's worth of faces).
        level : 1..5, adaptive isolation level of the limit patches around extraordinary vertices
            and density of the limit samples that seed the closest-point search (2**min(level, 3) + 1
            per control edge). The thesis used subdivision levels 2-3.
        min_quality : sliver guard of the decimation, in [0, 1) (1 = equilateral).
        fit_iterations : least-squares fits of the control vertices to the dense mesh, each
            followed by a re-bind; 0 keeps the decimated positions.
        fit_regularization : Tikhonov weight of the fit, pulling each control vertex towards its
            decimated position (relative to the normal equations' mean diagonal).
        projection_iterations : Gauss-Newton steps of the closest-point projection.
        progress : optional callable(fraction) -> bool|None; returning False cancels
            (dgmesh.Cancelled).
        """
        V = as_vertices(V)
        F = as_faces(F, n=len(V))
        o = make_options(MultiresOptions(), control_faces=as_count(control_faces, "control_faces"),
                         level=as_count(level, "level"), min_quality=min_quality,
                         fit_iterations=as_count(fit_iterations, "fit_iterations"),
                         fit_regularization=fit_regularization,
                         projection_iterations=as_count(projection_iterations, "projection_iterations"))
        return cls(_native.Multires.build(V, F, o, progress))

    @classmethod
    def bind(cls, control_vertices: npt.ArrayLike, control_faces: npt.ArrayLike, V: npt.ArrayLike, *,
             level: int = _D.level, projection_iterations: int = _D.projection_iterations,
             progress: Progress | None = None) -> "Multires":
        """Binds the points V to the limit surface of a given control mesh (no decimation, no fit);
        ``level`` and ``projection_iterations`` as in :meth:`build`."""
        return cls(_native.Multires.bind(as_vertices(control_vertices, "control_vertices"),
                                         as_faces(control_faces, "control_faces"), as_vertices(V),
                                         as_count(level, "level"),
                                         as_count(projection_iterations, "projection_iterations"), progress))

    # -- persistence ----------------------------------------------------------------------------
    def __reduce__(self) -> tuple[Any, tuple[dict[str, np.ndarray]]]:
        # pickle / copy.deepcopy through the exact array round trip (e.g. to send it to another process)
        return (type(self).from_arrays, (self.to_arrays(),))

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The bind data as plain numpy arrays (a dict), enough to rebuild this object exactly with
        :meth:`from_arrays`: control_vertices (rest pose), control_faces, level, base_face,
        base_st, displacement, and format_version."""
        m = self._m
        return {
            "format_version": np.int32(FORMAT_VERSION),
            "control_vertices": m.control_vertices,
            "control_faces": m.control_faces,
            "level": np.int32(m.level),
            "base_face": np.asarray(m.base_face, dtype=np.int32),
            "base_st": m.base_st,
            "displacement": m.displacement,
        }

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, npt.ArrayLike]) -> "Multires":
        """Rebuilds a binding from :meth:`to_arrays` output (a dict or an ``np.load`` archive).
        Raises MeshError on missing or inconsistent data."""
        missing = [k for k in _KEYS if k not in arrays]
        if missing:
            raise MeshError(f"multires data lacks {', '.join(missing)}")
        version = as_count(_single(arrays.get("format_version", FORMAT_VERSION)), "multires data format_version",
                           -INT_MAX - 1)
        if version != FORMAT_VERSION:
            raise MeshError(f"multires data has format version {version}, this dgmesh reads {FORMAT_VERSION}")
        face = np.asarray(arrays["base_face"])
        if face.ndim != 1 or (face.size and not np.issubdtype(face.dtype, np.integer)):
            raise MeshError("base_face must be a one-dimensional integer array")
        st = np.ascontiguousarray(arrays["base_st"], dtype=np.float64)
        if st.ndim != 2 or st.shape[1] != 2:
            raise MeshError(f"base_st must have shape (n, 2), got {st.shape}")
        return cls(_native.Multires.from_arrays(
            as_vertices(arrays["control_vertices"], "control_vertices"),
            as_faces(arrays["control_faces"], "control_faces"),
            as_count(_single(arrays["level"]), "multires data level"),
            np.ascontiguousarray(face, dtype=np.int32), st,
            as_vertices(arrays["displacement"], "displacement")))

    def save(self, path: str | bytes | os.PathLike) -> None:
        """Writes the bind data to an ``.npz`` archive."""
        with open(path, "wb") as fh:  # a file object: numpy would add ".npz" to a path without it
            np.savez_compressed(fh, **self.to_arrays())

    @classmethod
    def load(cls, path: str | bytes | os.PathLike) -> "Multires":
        """Reads bind data written by :meth:`save`."""
        with np.load(path) as data:
            return cls.from_arrays({k: data[k] for k in data.files})

    # -- evaluation -----------------------------------------------------------------------------
    def reconstruct(self, control_vertices: npt.ArrayLike, out: np.ndarray | None = None) -> np.ndarray:
        """Dense vertex positions for new control vertex positions ((n_control, 3)).

        With ``out`` (a C-contiguous float64 or float32 (n_dense, 3) array) the result is written
        there and ``out`` is returned, which avoids allocating for every frame of an interactive
        edit; float32 suits Blender's ``foreach_set`` directly (computed in double, then rounded).
        The GIL is released while the native code runs."""
        X = as_vertices(control_vertices, "control_vertices")
        if out is None:
            return self._m.reconstruct(X)
        if not (isinstance(out, np.ndarray) and out.dtype in (np.float64, np.float32) and out.flags.c_contiguous
                and out.shape == (self.n_dense, 3) and out.flags.writeable):
            raise MeshError(f"out must be a writable C-contiguous float64 or float32 array of shape ({self.n_dense}, 3)")
        self._m.reconstruct(X, out)
        return out

    def limit_points(self, control_vertices: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(points, normals): the base points S(f, s, t) of the dense vertices on the limit surface
        and the unit limit normals there, for the given (default: rest) control vertices."""
        X = self._m.control_vertices if control_vertices is None else as_vertices(control_vertices)
        return self._m.limit_points(X)

    def evaluate(self, face: npt.ArrayLike, st: npt.ArrayLike,
                 control_vertices: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Limit positions and derivatives (P, dP/ds, dP/dt) at locations (face[i], st[i]) of the
        control mesh (s, t >= 0, s + t <= 1; corners 0, 1, 2 of a face at (0,0), (1,0), (0,1))."""
        X = self._m.control_vertices if control_vertices is None else as_vertices(control_vertices)
        face = np.asarray(face).reshape(-1)
        if face.size and not np.issubdtype(face.dtype, np.integer):
            raise MeshError(f"face must hold integer face indices, got {face.dtype}")
        face = np.ascontiguousarray(face, dtype=np.int32)
        st = np.ascontiguousarray(st, dtype=np.float64).reshape(-1, 2)
        return self._m.evaluate(X, face, st)

    def limit_matrix(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]:
        """Position weights of the base points over the control vertices, as (data, indices,
        indptr, shape) of a CSR matrix W (n_dense x n_control, rows sum to 1) with
        ``limit_points = W @ control_vertices``; pass it to ``scipy.sparse.csr_matrix``."""
        return self._m.limit_matrix()

    # -- properties -----------------------------------------------------------------------------
    @property
    def control_vertices(self) -> np.ndarray:
        """(n_control, 3) rest positions of the control mesh."""
        return self._m.control_vertices

    @property
    def control_faces(self) -> np.ndarray:
        """(m_control, 3) triangles of the control mesh."""
        return self._m.control_faces

    @property
    def level(self) -> int:
        return self._m.level

    @property
    def n_dense(self) -> int:
        return self._m.n_dense

    @property
    def n_control(self) -> int:
        return self._m.n_control

    @property
    def base_face(self) -> np.ndarray:
        return self._m.base_face

    @property
    def base_st(self) -> np.ndarray:
        return self._m.base_st

    @property
    def displacement(self) -> np.ndarray:
        """(n_dense, 3) displacement (a, b, c) in the frame (t1, t2, n) of each base point."""
        return self._m.displacement

    @property
    def normal_displacement(self) -> np.ndarray:
        """(n_dense,) the DSS scalar c: signed distance along the limit normal."""
        return self._m.displacement[:, 2].copy()

    @property
    def displacement_magnitude(self) -> np.ndarray:
        """(n_dense,) |x - S|: distance of each dense vertex from its base point."""
        return np.linalg.norm(self._m.displacement, axis=1)

    @property
    def memory_bytes(self) -> int:
        """Bytes held by the stencils and bind data."""
        return self._m.memory_bytes

    @property
    def timings(self) -> MultiresTimings:
        """Seconds spent in each build stage: ``decimate``, ``surface``, ``bind``, ``fit``,
        ``stencils`` (a :class:`MultiresTimings`)."""
        return self._m.timings

    def __repr__(self) -> str:
        return (f"Multires({self.n_dense} dense vertices on {self.n_control} control vertices / "
                f"{len(self._m.control_faces)} faces, level {self.level})")
