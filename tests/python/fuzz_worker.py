"""The child process of the fuzz suite (test_fuzz.py): runs one case at a time and reports a verdict,
so a crash (segfault, abort) kills only this process and the parent names the case that caused it.

Protocol: the parent writes pickled cases to stdin, each preceded by its length (8 bytes, little
endian); for each this process answers the same way with a pickled verdict: None when the outcome
is acceptable, else a sentence saying what is wrong. A case is (call, mesh, options, named):
``call`` a key of CALLS, ``mesh`` the recipe of build_mesh, ``options`` the keyword arguments and
``named`` the option whose value has the wrong type (the call must fail with an error naming it),
or None.

Acceptable outcomes: a result whose numbers are finite (inf only in the stretch metrics, which
document it for zero-area UV triangles), or a dgmesh.Error, ValueError or TypeError with a message
that is not one of Python's or pybind11's generic ones.
"""

import os
import pickle
import struct
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.environ.get("DGMESH_PACKAGE_DIR")
                or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
import dgmesh  # noqa: E402

# Messages that say nothing about the bad value: Python's and pybind11's own.
GENERIC = ("incompatible function arguments", "Unable to cast", "argument must be", "could not convert",
           "unsupported operand", "object is not", "has no attribute", "not subscriptable", "index out of bounds",
           "invalid literal")
# Results documented to be inf in some cases: the stretch of a zero-area UV triangle (UvMetrics's
# stretch_* fields, uv_stretch).
def may_be_inf(where):
    return where.startswith("uv_stretch") or ".stretch_" in where


def _tet():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return V, F


def _two_spheres():
    V, F = dgmesh.shapes.icosphere(0)
    return np.vstack([V, V + 3]), np.vstack([F, F + len(V)])


BASES = {
    "icosphere": lambda: dgmesh.shapes.icosphere(1),
    "grid": lambda: dgmesh.shapes.grid(3, 3),
    "torus": lambda: dgmesh.shapes.torus(1.0, 0.4, 6, 4),
    "tetrahedron": _tet,
    "triangle": lambda: (np.eye(3), np.array([[0, 1, 2]])),
    "two_spheres": _two_spheres,
    "empty": lambda: (np.zeros((0, 3)), np.zeros((0, 3), int)),
}
# Mutations that leave a valid mesh valid: an option of the wrong type must then be the error's
# subject (with a broken mesh, an error about the mesh is as good).
VALID = {"none", "noise", "float32", "int64", "fortran"}
MUTATIONS = sorted(VALID | {"tiny", "degenerate_face", "duplicate_face", "flip_face", "collapse", "loose_vertex",
                            "drop_face", "planar", "nan", "inf", "huge", "index_oob", "negative_index",
                            "four_columns", "no_faces", "no_vertices"})


def build_mesh(base, mutation, i, f, k, number):
    """(V, F) from a recipe: a base mesh, a mutation, and the vertex i, face f, column k and number
    it uses (indices are taken modulo the mesh's size)."""
    V, F = BASES[base]()
    V, F = np.array(V, dtype=np.float64), np.array(F, dtype=np.int64)
    n, m = len(V), len(F)
    i, f = (i % n if n else 0), (f % m if m else 0)
    if mutation == "noise" and n:
        V = V + np.random.default_rng(number).normal(0, 0.05, V.shape)
    elif mutation in ("nan", "inf") and n:
        V[i, k] = np.nan if mutation == "nan" else -np.inf
    elif mutation == "huge":
        V = V * (1e40, 1e49, 1e200)[k]
    elif mutation == "tiny":
        V = V * (1e-150, 1e-300, 1e-320)[k]
    elif mutation == "planar":
        V[:, 2] = 0.0
    elif mutation == "index_oob" and m:
        F[f, k] = n + number
    elif mutation == "negative_index" and m:
        F[f, k] = -1 - number
    elif mutation == "degenerate_face" and m:
        F[f, 1] = F[f, 0]
    elif mutation == "duplicate_face" and m:
        F = np.vstack([F, F[f]])
    elif mutation == "flip_face" and m:
        F[f] = F[f, ::-1]
    elif mutation == "collapse" and m:
        V[F[f, 1]] = V[F[f, 0]]
    elif mutation == "loose_vertex":
        V = np.vstack([V, [5.0, 5.0, 5.0]])
    elif mutation == "drop_face" and m:
        F = np.delete(F, f, axis=0)
    elif mutation == "float32":
        V = V.astype(np.float32)
    elif mutation == "int64":
        F = F.astype(np.int64)
    elif mutation == "fortran":
        V, F = np.asfortranarray(V), np.asfortranarray(F)
    elif mutation == "four_columns":
        F = np.hstack([F, F[:, :1]])
    elif mutation == "no_faces":
        F = F[:0]
    elif mutation == "no_vertices":
        V = V[:0]
    return V, F


def _bones():
    B = np.tile(np.eye(4), (2, 1, 1))
    B[1, 2, 3] = 0.5
    return B


def _multires(V, F, **kw):
    m = dgmesh.Multires.build(V, F, **kw)
    return m.reconstruct(m.control_vertices), m.to_arrays()


def _rig(V, F, **kw):
    rig = dgmesh.SkeletalRig.bind(V, F, _bones(), **kw)
    # A wild free-form edit: the skeletal vertices in reverse order.
    return rig.deform(_bones()), rig.deform_skeleton(rig.skeleton_vertices[::-1], _bones()), rig.to_arrays()


def _roundtrip(V, F, ext):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "m" + ext)
        dgmesh.write_mesh(path, V, F)
        return dgmesh.read_mesh(path)


def _uv(V):
    V = np.asarray(V)
    return V[:, :2] if V.ndim == 2 and V.shape[1:] == (3,) else V


# Every public function of dgmesh taking a mesh, called on (V, F) with the generated options.
CALLS = {
    "curvature": lambda V, F, **kw: dgmesh.curvature(V, F),
    "topology": lambda V, F, **kw: dgmesh.topology(V, F),
    "validate": lambda V, F, **kw: dgmesh.validate(V, F, **kw),
    "willmore_energy": lambda V, F, **kw: dgmesh.willmore_energy(V, F),
    "denoise": lambda V, F, **kw: dgmesh.denoise(V, F, **kw),
    "denoise_points": lambda V, F, **kw: dgmesh.denoise(V, None, V, **kw),
    "similarity": lambda V, F, **kw: dgmesh.similarity(V, F, **kw),
    "estimate_noise": lambda V, F, **kw: dgmesh.estimate_noise(V, F, **kw),
    "estimate_noise_points": lambda V, F, **kw: dgmesh.estimate_noise(V, None, **kw),
    "crest_lines": lambda V, F, **kw: dgmesh.crest_lines(V, F, **kw),
    "curvature_derivatives": lambda V, F, **kw: dgmesh.curvature_derivatives(V, F, **kw),
    "decimate": lambda V, F, **kw: dgmesh.decimate(V, F, **kw),
    "segment": lambda V, F, **kw: dgmesh.segment(V, F, **kw),
    "fair": lambda V, F, **kw: dgmesh.fair(V, F, **kw),
    "regularize": lambda V, F, **kw: dgmesh.regularize(V, F, **kw),
    "unwrap": lambda V, F, **kw: dgmesh.unwrap(V, F, **kw),
    "unwrap_charts": lambda V, F, **kw: dgmesh.unwrap_charts(V, F, np.zeros(len(np.asarray(F)), int), **kw),
    "auto_unwrap": lambda V, F, **kw: dgmesh.auto_unwrap(V, F, **kw),
    "uv_metrics": lambda V, F, **kw: dgmesh.uv_metrics(V, F, _uv(V), **kw),
    "uv_stretch": lambda V, F, **kw: dgmesh.uv_stretch(V, F, _uv(V), **kw),
    "skeletal_mesh": lambda V, F, **kw: dgmesh.skeletal_mesh(V, F, **kw),
    "delaunay_2d": lambda V, F, **kw: dgmesh.delaunay_2d(_uv(V)),
    "delaunay_3d": lambda V, F, **kw: dgmesh.delaunay_3d(V),
    "union_of_balls_distance": lambda V, F, **kw: dgmesh.union_of_balls_distance(V, V, np.ones(len(np.asarray(V)))),
    "point_mesh_distance": lambda V, F, **kw: dgmesh.point_mesh_distance(np.asarray(V) * 0.5, V, F, **kw),
    "remesh": lambda V, F, **kw: dgmesh.remesh(V, F, **kw),
    "remesh_full": lambda V, F, **kw: dgmesh.remesh_full(V, F, **kw),
    "multires": _multires,
    "skeletal_rig": _rig,
    "obj": lambda V, F, **kw: _roundtrip(V, F, ".obj"),
    "off": lambda V, F, **kw: _roundtrip(V, F, ".off"),
    "ply": lambda V, F, **kw: _roundtrip(V, F, ".ply"),
    "loop_subdivide": lambda V, F, **kw: dgmesh.shapes.loop_subdivide(V, F, **kw),
    # the shapes take no mesh
    "icosphere": lambda V, F, **kw: dgmesh.shapes.icosphere(**kw),
    "grid": lambda V, F, **kw: dgmesh.shapes.grid(**kw),
    "torus": lambda V, F, **kw: dgmesh.shapes.torus(**kw),
}


def nonfinite(value, where, depth=0):
    """The first place in a result holding NaN (or inf outside may_be_inf), or None."""
    if depth > 6:
        return None
    if isinstance(value, (float, np.floating)):
        bad = np.isnan(value) or (np.isinf(value) and not may_be_inf(where))
        return where if bad else None
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc":
            ok = ~np.isnan(value) if may_be_inf(where) else np.isfinite(value)
            return None if ok.all() else where
        return None
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, (list, tuple)):
        items = enumerate(value)
    elif hasattr(type(value), "__fields__"):
        items = ((k, getattr(value, k)) for k in type(value).__fields__)
    else:
        return None
    for k, v in items:
        found = nonfinite(v, f"{where}.{k}" if isinstance(k, str) else f"{where}[{k}]", depth + 1)
        if found:
            return found
    return None


def verdict(call, mesh, options, named):
    if call == "crash":  # the harness's own test: dies as a segfault would
        os.abort()
    V, F = build_mesh(*mesh)
    try:
        result = CALLS[call](V, F, **options)
    except (dgmesh.Error, ValueError, TypeError) as exc:
        msg = str(exc)
        if not msg.strip() or any(g in msg for g in GENERIC):
            return f"{type(exc).__name__} with a generic message: {msg[:300]!r}"
        if named and not any(name in msg for name in options):  # another option may be out of range
            return f"{type(exc).__name__} does not name {named!r}: {msg[:300]!r}"
        return None
    except Exception as exc:  # noqa: BLE001 - anything else is the finding
        return f"unexpected {type(exc).__name__}: {str(exc)[:300]!r}"
    if named:
        return f"accepted {named}={options[named]!r}"
    where = nonfinite(result, call)
    if where:
        return f"non-finite value in {where}"
    return None


def main():
    dgmesh.set_num_threads(1)  # the suite runs beside other work
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while True:
        head = inp.read(8)
        if len(head) < 8:
            return
        case = pickle.loads(inp.read(struct.unpack("<Q", head)[0]))
        data = pickle.dumps(verdict(*case))
        out.write(struct.pack("<Q", len(data)) + data)
        out.flush()


if __name__ == "__main__":
    main()
