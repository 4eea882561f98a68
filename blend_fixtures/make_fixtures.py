"""Build the .blend test fixtures (run inside Blender).

    blender --background --factory-startup --python-exit-code 1 \
        --python blend_fixtures/make_fixtures.py -- [outdir]

outdir defaults to this folder.  Files written (all small, committed):
  shapes.blend        quads + triangle poles, n-gon caps, subdivided cube, torus
                      (negative Gaussian curvature), a mesh with a loose vertex
  bad_meshes.blend    one object per kind of invalid mesh; each object has a
                      custom property "dg_expect_error" (a word the error names)
  data_survival.blend UVs, vertex groups, custom attributes, an existing colour
                      attribute, custom split normals; and a mesh with a shape
                      key and a modifier

The module is also imported by tests and scripts/demo.py for the helpers
add_mesh_object() and load_cgal_object() (scanned models from Debian's CGAL
data, unpacked at run time into $DGMESH_DATA, default <repo>/.cache/cgal-data;
never committed).
"""

import math
import os
import sys
import tarfile
from pathlib import Path

import bmesh
import bpy
import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
CGAL_TARBALLS = (
    Path("/usr/share/doc/libcgal-dev/data.tar.gz"),
    Path("/usr/share/doc/libcgal-demo/data.tar.gz"),
)


# --- building meshes ----------------------------------------------------------------------

def add_mesh_object(name, V, faces, collection=None, location=(0.0, 0.0, 0.0)):
    """New mesh object from vertices (n, 3) and faces, linked to ``collection``
    (default: the scene collection).  ``faces`` is an (m, k) int array or a
    list of index lists (mixed sizes allowed).  No validation: bad meshes are
    built on purpose."""
    V = np.asarray(V, dtype=np.float32).reshape(-1, 3)
    if isinstance(faces, np.ndarray):
        faces2d = faces.reshape(len(faces), -1)
        sizes = np.full(len(faces2d), faces2d.shape[1], dtype=np.int32)
        corners = faces2d.astype(np.int32).ravel()
    else:
        sizes = np.array([len(f) for f in faces], dtype=np.int32)
        corners = np.array([i for f in faces for i in f], dtype=np.int32)
    starts = np.zeros(len(sizes), dtype=np.int32)
    if len(sizes):
        starts[1:] = np.cumsum(sizes)[:-1]

    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", V.ravel())
    mesh.loops.add(len(corners))
    mesh.loops.foreach_set("vertex_index", corners)
    mesh.polygons.add(len(sizes))
    mesh.polygons.foreach_set("loop_start", starts)
    # Blender 4.x derives polygon sizes from the start offsets (loop_total is
    # read-only there); 3.x needs them set.
    if not bpy.types.MeshPolygon.bl_rna.properties["loop_total"].is_readonly:
        mesh.polygons.foreach_set("loop_total", sizes)
    mesh.update(calc_edges=True)
    return _link(bpy.data.objects.new(name, mesh), collection, location)


def _link(obj, collection, location):
    obj.location = location
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def bmesh_object(name, build, collection=None, location=(0.0, 0.0, 0.0), uvs=False):
    """New mesh object filled by ``build(bm)`` (a function calling bmesh.ops)."""
    bm = bmesh.new()
    if uvs:
        bm.loops.layers.uv.new("UVMap")  # bmesh.ops calc_uvs fills the active UV layer
    build(bm)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return _link(bpy.data.objects.new(name, mesh), collection, location)


def torus_arrays(R=1.0, r=0.35, nu=32, nv=16):
    """Quad torus in the xy plane: (V, F) with F (nu*nv, 4)."""
    u = np.arange(nu) * (2 * np.pi / nu)
    v = np.arange(nv) * (2 * np.pi / nv)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    V = np.stack([(R + r * np.cos(vv)) * np.cos(uu),
                  (R + r * np.cos(vv)) * np.sin(uu),
                  r * np.sin(vv)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    return V, np.stack([a, b, c, d], axis=-1).reshape(-1, 4)


def _icosphere_arrays(subdivisions=1, radius=1.0):
    """(V, F) of a triangulated icosphere, via bmesh."""
    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=subdivisions, radius=radius)
    V = np.array([v.co[:] for v in bm.verts])
    F = np.array([[v.index for v in f.verts] for f in bm.faces])
    bm.free()
    return V, F


# --- scanned models (CGAL data) -------------------------------------------------------------

def cgal_data_dir():
    """Cache dir holding data/meshes/*.off (same layout as scripts/cgal_data.sh)."""
    return Path(os.environ.get("DGMESH_DATA", REPO / ".cache" / "cgal-data"))


def cgal_mesh_path(name):
    """Path of data/meshes/<name>.off, unpacked from the CGAL tarball on first use."""
    fname = name if name.endswith(".off") else name + ".off"
    path = cgal_data_dir() / "data" / "meshes" / fname
    if path.is_file():
        return path
    tarball = next((t for t in CGAL_TARBALLS if t.is_file()), None)
    if tarball is None:
        raise FileNotFoundError("CGAL data not found (apt-get install libcgal-dev or libcgal-demo)")
    member = f"data/meshes/{fname}"
    with tarfile.open(tarball) as tar:
        try:
            info = tar.getmember(member)
        except KeyError:
            raise FileNotFoundError(f"{member} is not in {tarball}") from None
        tar.extract(info, cgal_data_dir())
    return path


def read_off(path):
    """Minimal OFF reader: (V float64 (n, 3), faces) where faces is an (m, k)
    array if all faces have k corners, else a list of lists."""
    lines = []
    with open(path) as fh:
        for line in fh:
            line = line.split("#", 1)[0].strip()
            if line:
                lines.append(line)
    header = lines[0]
    if not header.endswith("OFF"):
        raise ValueError(f"{path}: not an OFF file")
    rest = lines[1:] if header == "OFF" else [header[3:]] + lines[1:]
    n, m = (int(t) for t in rest[0].split()[:2])
    V = np.array(" ".join(rest[1:1 + n]).split(), dtype=np.float64)
    if V.size != 3 * n:  # per-vertex colours or normals: keep x y z
        V = np.array([ln.split()[:3] for ln in rest[1:1 + n]], dtype=np.float64)
    rows = [ln.split() for ln in rest[1 + n:1 + n + m]]
    k = int(rows[0][0]) if rows else 3
    if all(len(r) == k + 1 and r[0] == str(k) for r in rows):
        return V.reshape(n, 3), np.array(rows, dtype=np.int64)[:, 1:]
    return V.reshape(n, 3), [[int(t) for t in r[1:1 + int(r[0])]] for r in rows]


def load_cgal_object(name, collection=None, location=(0.0, 0.0, 0.0)):
    """Mesh object for a CGAL data model, e.g. "bunny00", "fandisk", "armadillo"."""
    path = cgal_mesh_path(name)
    try:
        import dgmesh  # the native reader, when the add-on is importable
        V, F = dgmesh.read_mesh(str(path))
    except ImportError:
        V, F = read_off(path)
    return add_mesh_object(Path(path).stem, V, F, collection, location)


# --- fixture files ----------------------------------------------------------------------------

def _reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _save(outdir, filename):
    path = Path(outdir) / filename
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, check_existing=False)
    print(f"wrote {path} ({path.stat().st_size // 1024} KB)")
    return path


def make_shapes(outdir):
    _reset()
    bmesh_object("QuadSphere", lambda bm: bmesh.ops.create_uvsphere(
        bm, u_segments=24, v_segments=12, radius=1.0), location=(0, 0, 0))
    bmesh_object("NgonCylinder", lambda bm: bmesh.ops.create_cone(
        bm, cap_ends=True, cap_tris=False, segments=16, radius1=1.0, radius2=1.0, depth=2.0),
        location=(3, 0, 0))

    def subdivided_cube(bm):
        bmesh.ops.create_cube(bm, size=2.0)
        bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=3, use_grid_fill=True)
    bmesh_object("SubdivCube", subdivided_cube, location=(6, 0, 0))
    add_mesh_object("Torus", *torus_arrays(), location=(0, 3, 0))

    V, F = _icosphere_arrays(subdivisions=2)
    add_mesh_object("LooseVertex", np.vstack([V, [[2.0, 0.0, 0.0]]]), F, location=(3, 3, 0))
    return _save(outdir, "shapes.blend")


def make_bad_meshes(outdir):
    _reset()
    col = bpy.context.scene.collection
    # Each object: (name, V, faces, a word the native error message contains).
    tet_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    tet_F = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
    ico_V, ico_F = _icosphere_arrays(subdivisions=1)
    nan_V = ico_V.copy()
    nan_V[5, 1] = np.nan
    # Two closed fans (cones) sharing their apex 0.
    fan_V = [(0, 0, 0)]
    fan_F = []
    for side in (1.0, -1.0):
        base = len(fan_V)
        for k in range(5):
            a = 2 * math.pi * k / 5
            fan_V.append((math.cos(a), math.sin(a), side))
        for k in range(5):
            i, j = base + k, base + (k + 1) % 5
            fan_F.append((0, i, j) if side > 0 else (0, j, i))
    flipped_F = [tuple(f) for f in tet_F]
    flipped_F[2] = flipped_F[2][::-1]
    cases = [
        ("Bad_NaN", nan_V, ico_F, "nan"),
        # 0, 1, 2 collinear: face (0, 2, 1) has zero area; the rest is a valid strip.
        ("Bad_ZeroArea", [(0, 0, 0), (1, 0, 0), (2, 0, 0), (1, 1, 0)],
         [(0, 1, 3), (1, 2, 3), (0, 2, 1)], "zero area"),
        ("Bad_DuplicateFaces", tet_V, tet_F + [tet_F[1]], "duplicate"),
        # Three triangles around edge 0-1.
        ("Bad_NonManifoldEdge", [(0, 0, 0), (1, 0, 0), (0.5, 1, 0), (0.5, -1, 0), (0.5, 0, 1)],
         [(0, 1, 2), (1, 0, 3), (0, 1, 4)], "non-manifold"),
        ("Bad_NonManifoldVertex", fan_V, fan_F, "non-manifold"),
        ("Bad_Empty", np.zeros((0, 3)), [], "empty"),
        ("Bad_FlippedFace", tet_V, flipped_F, "orient"),
    ]
    for i, (name, V, F, expect) in enumerate(cases):
        obj = add_mesh_object(name, V, F, col, location=(3 * i, 0, 0))
        obj["dg_expect_error"] = expect  # on the object, so the mesh stays as built
    return _save(outdir, "bad_meshes.blend")


def make_data_survival(outdir):
    _reset()
    obj = bmesh_object("DataRich", lambda bm: bmesh.ops.create_uvsphere(
        bm, u_segments=16, v_segments=8, radius=1.0, calc_uvs=True), uvs=True)
    mesh = obj.data
    n = len(mesh.vertices)
    z = np.empty(n * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", z)
    z = z.reshape(n, 3)[:, 2]

    group = obj.vertex_groups.new(name="Top")
    for i in np.flatnonzero(z > 0):
        group.add([int(i)], float(z[i]), 'REPLACE')
    obj.vertex_groups.new(name="Empty")

    a = mesh.attributes.new("my_float", 'FLOAT', 'POINT')
    a.data.foreach_set("value", np.linspace(0, 1, n, dtype=np.float32))
    a = mesh.attributes.new("my_face_int", 'INT', 'FACE')
    a.data.foreach_set("value", np.arange(len(mesh.polygons), dtype=np.int32))
    a = mesh.attributes.new("my_corner_vec", 'FLOAT_VECTOR', 'CORNER')
    a.data.foreach_set("vector", np.arange(len(mesh.loops) * 3, dtype=np.float32))
    c = mesh.color_attributes.new("my_color", 'BYTE_COLOR', 'CORNER')
    c.data.foreach_set("color", np.tile([0.2, 0.4, 0.6, 1.0], len(mesh.loops)).astype(np.float32))
    mesh.color_attributes.active_color = c
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), dtype=bool))
    # Custom split normals: 3.x needs auto smooth for them; 4.1 removed the option.
    if hasattr(mesh, "use_auto_smooth"):
        mesh.use_auto_smooth = True
    normals = np.zeros((len(mesh.loops), 3), dtype=np.float32)
    normals[:, 2] = 1.0
    mesh.normals_split_custom_set(normals)

    obj = bmesh_object("ShapeKeyed", lambda bm: bmesh.ops.create_uvsphere(
        bm, u_segments=16, v_segments=8, radius=1.0), location=(3, 0, 0))
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Squash")
    co = np.empty(len(key.data) * 3, dtype=np.float32)
    key.data.foreach_get("co", co)
    co = co.reshape(-1, 3) * np.array([1.2, 1.2, 0.6], dtype=np.float32)
    key.data.foreach_set("co", co.ravel())
    key.value = 0.5
    obj.modifiers.new("Subdivision", 'SUBSURF').levels = 1
    return _save(outdir, "data_survival.blend")


FIXTURES = (make_shapes, make_bad_meshes, make_data_survival)


def main(argv):
    outdir = Path(argv[0]) if argv else HERE
    outdir.mkdir(parents=True, exist_ok=True)
    for make in FIXTURES:
        make(outdir)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
