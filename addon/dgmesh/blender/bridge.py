"""The one place where data moves between Blender meshes and numpy.

Reading uses ``foreach_get`` into typed buffers (no per-vertex Python loops);
faces are taken from Blender's own loop triangulation so quads and n-gons are
triangulated exactly as the viewport shows them.  Writing helpers only touch
the data they are asked to write: every other attribute, UV map, vertex group
and shape key is left alone.

Edit mode: the edit-mesh (BMesh) is the real data while an object is in Edit
mode and it overwrites the mesh datablock when Edit mode is left, so
* reading first syncs it into the mesh (``update_from_editmode``);
* writing goes through :func:`object_mode`, which leaves Edit mode, lets the
  caller write to the mesh datablock and re-enters Edit mode (the edit-mesh is
  then rebuilt from the mesh, including the new attributes).  Doing it with
  bmesh instead would need a Python loop per vertex.
"""

from contextlib import contextmanager
from dataclasses import dataclass
from typing import Optional

import bmesh
import bpy
import numpy as np

from . import compat


@dataclass
class MeshArrays:
    """Triangulated mesh arrays, ready for the native library."""

    V: np.ndarray  # (n, 3) float64 vertex positions (object space)
    F: np.ndarray  # (m, 3) int32 vertex indices of each triangle
    tri_loops: np.ndarray  # (m, 3) int32 loop (face corner) indices of each triangle
    tri_poly: np.ndarray  # (m,) int32 polygon each triangle comes from
    edges: Optional[np.ndarray] = None  # (e, 2) int32, only when asked for

    @property
    def num_vertices(self):
        return len(self.V)


def read_mesh(mesh, edges=False):
    """Read a mesh datablock into :class:`MeshArrays` (it is not modified).

    ``calc_loop_triangles`` only fills a runtime cache, it writes no mesh data.
    """
    n = len(mesh.vertices)
    co = np.empty(n * 3, dtype=np.float32)  # Blender stores float32
    mesh.vertices.foreach_get("co", co)
    V = np.ascontiguousarray(co.reshape(n, 3), dtype=np.float64)

    mesh.calc_loop_triangles()
    tris = mesh.loop_triangles
    m = len(tris)
    F = np.empty(m * 3, dtype=np.int32)
    tris.foreach_get("vertices", F)
    tri_loops = np.empty(m * 3, dtype=np.int32)
    tris.foreach_get("loops", tri_loops)
    tri_poly = np.empty(m, dtype=np.int32)
    tris.foreach_get("polygon_index", tri_poly)

    E = None
    if edges:
        E = np.empty(len(mesh.edges) * 2, dtype=np.int32)
        mesh.edges.foreach_get("vertices", E)
        E = E.reshape(-1, 2)
    return MeshArrays(V, F.reshape(m, 3), tri_loops.reshape(m, 3), tri_poly, E)


def repair_ngon_triangles(arrays, rel_area=1e-12, max_rounds=8):
    """Re-triangulates n-gons whose loop triangulation the native library would reject.

    Blender's ear clipping may cut an "ear" of three collinear corners (an n-gon with a vertex in
    the middle of a straight side, e.g. after dissolving edges): a zero-area triangle. Two n-gons
    sharing two consecutive sides (a valence-2 vertex between them) may both cut the ear at that
    vertex: the same triangle twice, back to back. Each such ear (a, b, c), b the corner whose two
    sides are polygon sides, shares its diagonal with another triangle (a, c, d) of its polygon;
    flipping that diagonal gives (b, c, d) and (b, d, a). Rounds repeat for runs of such corners.
    With the mesh's edges (``read_object(edges=True)``), triangles folded against their polygon are
    flipped too (:func:`_unfold_ngon_triangles`).
    Triangles, their loops and polygons stay consistent; the mesh is not touched. Returns new
    :class:`MeshArrays` (the same object when nothing needed repair); what cannot be repaired is
    left for validation to report.
    """
    V, F, L, P = arrays.V, arrays.F.copy(), arrays.tri_loops.copy(), arrays.tri_poly
    if len(F) == 0:
        return arrays
    diag2 = float(((V.max(0) - V.min(0)) ** 2).sum())
    tol = rel_area * max(diag2, np.finfo(float).tiny)
    nv = np.int64(len(V))
    count = np.bincount(P, minlength=int(P.max()) + 1)
    multi = np.flatnonzero(count[P] > 1)  # triangles of n-gons (quads included): the only suspects
    if multi.size == 0:
        return arrays
    real = None  # the mesh's edges, a set made only when something needs repair (0.3 s at 1M)

    def area(f):  # twice the area, of (k, 3) index rows
        return np.linalg.norm(np.cross(V[f[:, 1]] - V[f[:, 0]], V[f[:, 2]] - V[f[:, 0]]), axis=1)

    def is_real(x, y):
        return real is not None and min(x, y) * nv + max(x, y) in real

    changed = False
    for _ in range(max_rounds):
        bad = np.zeros(len(F), bool)
        bad[multi] = area(F[multi]) <= 2 * tol
        key = np.sort(F.astype(np.int64), axis=1) @ np.array([nv * nv, nv, 1], dtype=np.int64)
        _, first = np.unique(key, return_index=True)
        dup = np.ones(len(F), bool)
        dup[first] = False  # every copy after the first
        bad = np.flatnonzero((bad | dup) & (count[P] > 1))  # triangles of n-gons only
        if bad.size == 0:
            break
        if real is None and arrays.edges is not None and len(arrays.edges):
            E = np.sort(arrays.edges.astype(np.int64), axis=1)
            real = set((E[:, 0] * nv + E[:, 1]).tolist())
        members = {}
        for t in np.flatnonzero(np.isin(P, np.unique(P[bad]))).tolist():
            members.setdefault(int(P[t]), []).append(t)
        progress = False
        for t in bad.tolist():
            f = F[t].tolist()
            # b: the ear corner (its two sides are polygon sides, the third side a diagonal);
            # without edges, the corner opposite the longest side (the middle of collinear ones).
            ears = [k for k in range(3) if is_real(f[k], f[(k + 1) % 3]) and is_real(f[k], f[(k + 2) % 3])
                    and not is_real(f[(k + 1) % 3], f[(k + 2) % 3])]
            if len(ears) == 1:
                k = ears[0]
            else:
                k = int(np.argmax([np.linalg.norm(V[f[(k + 2) % 3]] - V[f[(k + 1) % 3]]) for k in range(3)]))
            b, c, a = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
            lb, lc, la = int(L[t, k]), int(L[t, (k + 1) % 3]), int(L[t, (k + 2) % 3])
            for u in members[int(P[t])]:
                if u == t:
                    continue
                g = F[u].tolist()
                # The neighbour holds the directed edge a -> c.
                j = next((j for j in range(3) if g[j] == a and g[(j + 1) % 3] == c), None)
                if j is None:
                    continue
                d, ld = g[(j + 2) % 3], int(L[u, (j + 2) % 3])
                new = np.array([[b, c, d], [b, d, a]])
                if (area(new) <= 2 * tol).any():
                    break
                F[t], F[u] = new
                L[t], L[u] = (lb, lc, ld), (lb, ld, la)
                changed = progress = True
                break
        if not progress:
            break
    changed |= _unfold_ngon_triangles(arrays, F, L, multi, max_rounds)
    if not changed:
        return arrays
    return MeshArrays(arrays.V, F, L, P, arrays.edges)


def _unfold_ngon_triangles(arrays, F, L, multi, max_rounds):
    """Flips, in place in ``F`` and ``L``, diagonals of n-gon triangles (indices ``multi``) that face
    against their polygon; returns whether any changed. A bent or concave n-gon may be cut into a
    triangle folded back over its neighbour (how depends on the Blender version: 5.x triangulates
    by vertex positions), and curvature estimated across the fold is garbage (a crest line along
    a rounded edge of hexagons broke there). A polygon's normal is its vector area, the sum of
    its triangles' (the same for every triangulation of it). Triangle (x, y, z) and its neighbour
    (y, x, w) across diagonal x-y become (z, x, w) and (w, y, z) when both then face with the
    polygon. Needs the mesh's edges to tell diagonals from polygon sides."""
    E, V, P = arrays.edges, arrays.V, arrays.tri_poly
    if E is None or not len(E) or multi.size == 0:
        return False

    def cross(f):  # (k, 3) index rows
        return np.cross(V[f[:, 1]] - V[f[:, 0]], V[f[:, 2]] - V[f[:, 0]])

    normal = np.zeros((int(P.max()) + 1, 3))
    np.add.at(normal, P[multi], cross(F[multi]))
    bad = multi[np.einsum("ij,ij->i", cross(F[multi]), normal[P[multi]]) <= 0]
    if bad.size == 0:
        return False
    nv = int(len(V))
    E = np.sort(E.astype(np.int64), axis=1)
    real = set((E[:, 0] * nv + E[:, 1]).tolist())
    suspects = np.flatnonzero(np.isin(P, np.unique(P[bad])))
    members = {}
    for t in suspects.tolist():
        members.setdefault(int(P[t]), []).append(t)

    def flip(t):
        n = normal[P[t]]
        if cross(F[t:t + 1])[0] @ n > 0:  # already unfolded by an earlier flip
            return False
        f = F[t].tolist()
        for k in range(3):
            x, y, z = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
            if min(x, y) * nv + max(x, y) in real:
                continue
            for u in members[int(P[t])]:
                g = F[u].tolist()
                j = next((j for j in range(3) if g[j] == y and g[(j + 1) % 3] == x), None)
                if u == t or j is None:
                    continue
                w = g[(j + 2) % 3]
                new = np.array([[z, x, w], [w, y, z]])
                if w != z and (cross(new) @ n > 0).all():
                    lx, ly, lz = (int(L[t, (k + i) % 3]) for i in range(3))
                    lw = int(L[u, (j + 2) % 3])
                    F[t], F[u] = new
                    L[t], L[u] = (lz, lx, lw), (lw, ly, lz)
                    return True
                break
        return False

    changed = False
    for _ in range(max_rounds):
        progress = False
        for t in bad.tolist():
            progress |= flip(t)
        changed |= progress
        bad = suspects[np.einsum("ij,ij->i", cross(F[suspects]), normal[P[suspects]]) <= 0]
        if not progress or bad.size == 0:
            break
    return changed


def read_object(obj, evaluated=False, depsgraph=None, edges=False, sync=True):
    """Read a mesh object's data (positions in object space).

    ``evaluated=False`` reads the original mesh datablock, the one attributes
    are written to; modifiers are ignored.  ``evaluated=True`` reads the mesh
    after modifiers and shape keys (its vertex count may differ, so results on
    it cannot be stored as attributes of the original).
    In Edit mode the edit-mesh is synced into the datablock first (``sync=False``: the caller
    just did, e.g. :func:`has_selection`; a sync costs 0.44 s at 1M triangles).
    """
    if obj.type != 'MESH':
        raise TypeError(f"object {obj.name!r} is not a mesh")
    if obj.mode == 'EDIT' and sync:
        obj.update_from_editmode()
    if not evaluated:
        return read_mesh(obj.data, edges=edges)
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    obj_eval = obj.evaluated_get(depsgraph)
    mesh = obj_eval.to_mesh()
    try:
        return read_mesh(mesh, edges=edges)
    finally:
        obj_eval.to_mesh_clear()


def get_array(collection, key, dtype=bool, width=1):
    """One property of every element of a collection (``foreach_get``) as a numpy array, (n,) or
    (n, width)."""
    a = np.empty(width * len(collection), dtype=dtype)
    collection.foreach_get(key, a)
    return a.reshape(-1, width) if width > 1 else a


def ranges(start, count):
    """The concatenated index ranges [start[i], start[i] + count[i]) (e.g. the loops of polygons
    from their loop_start and loop_total), without a Python loop."""
    start, count = np.asarray(start), np.asarray(count)
    return np.repeat(start - np.cumsum(count) + count, count) + np.arange(count.sum())


def has_selection(obj, domain="vertices"):
    """Edit mode: whether the object has a shown, selected element of ``domain`` ("vertices" or
    "polygons"); one with none is no target of an operator, whatever else it holds."""
    obj.update_from_editmode()
    coll = getattr(obj.data, domain)
    return bool((get_array(coll, "select") & ~get_array(coll, "hide")).any())


def _check_rows(mesh, values, width, what):
    """One row per vertex: shape (n,) for width 1, else (n, width)."""
    n = len(mesh.vertices)
    expected = (n,) if width == 1 else (n, width)
    shape = np.shape(values)
    if shape != expected:
        raise ValueError(f"{what}: expected shape {expected}, got {shape}")


def write_positions(mesh, V):
    """Set vertex positions from an (n, 3) array and tag the mesh for redraw."""
    _check_rows(mesh, V, 3, "positions")
    mesh.vertices.foreach_set("co", np.ascontiguousarray(V, dtype=np.float32).ravel())
    mesh.update()


def _ensure_attribute(mesh, name, data_type, domain, color=False):
    """Return attribute ``name`` with the given type and domain, creating or
    replacing it (an existing one of another type/domain is removed)."""
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != data_type or attr.domain != domain):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        group = mesh.color_attributes if color else mesh.attributes
        group.new(name, data_type, domain)
    # Look it up again: adding/removing layers reallocates custom data, which
    # invalidates earlier Python references to attributes.
    return mesh.attributes[name]


def write_point_float(mesh, name, values):
    """Create or replace a FLOAT attribute on the POINT domain."""
    _check_rows(mesh, values, 1, name)
    attr = _ensure_attribute(mesh, name, 'FLOAT', 'POINT')
    attr.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.float32).ravel())
    mesh.update()
    return attr


def write_point_color(mesh, name, rgba, data_type='FLOAT_COLOR', make_active=True):
    """Create or replace a POINT colour attribute from (n, 4) linear RGBA.

    ``data_type`` is 'FLOAT_COLOR' or 'BYTE_COLOR' (the ``color`` property of
    both takes linear values).  With ``make_active`` it becomes the active and
    the render colour attribute, so Solid shading (Attribute colour) and the
    Color Attribute node without a name show it.
    """
    if data_type not in {'FLOAT_COLOR', 'BYTE_COLOR'}:
        raise ValueError(f"unsupported colour type {data_type!r}")
    _check_rows(mesh, rgba, 4, name)
    attr = _ensure_attribute(mesh, name, data_type, 'POINT', color=True)
    attr.data.foreach_set("color", np.ascontiguousarray(rgba, dtype=np.float32).ravel())
    if make_active:
        set_active_color(mesh, name)
    mesh.update()
    return mesh.attributes[name]


def set_active_color(mesh, name, render=None):
    """Make colour attribute ``name`` the active and the render (default) colour (or ``render``
    the render one)."""
    colors = mesh.color_attributes
    names = [a.name for a in colors]
    render = name if render is None else render
    for n in (name, render):
        if n not in names:
            raise KeyError(f"{mesh.name!r} has no colour attribute {n!r}")
    compat.set_color_names(colors, name, render)


def active_color_name(mesh):
    """Name of the active colour attribute, or None (same on 3.4 and 4.x)."""
    attr = mesh.color_attributes.active_color
    return attr.name if attr is not None else None


@contextmanager
def object_mode(context):
    """Temporarily leave Edit mode so mesh datablocks can be written.

    Leaving Edit mode writes every edited object's edit-mesh to its mesh; on
    exit Edit mode is re-entered for the same objects (mode_set alone enters it
    for the selected ones, which need not be those) and rebuilds the edit-meshes
    from the (written) datablocks.  Outside Edit mode this does nothing.
    """
    layer = context.view_layer
    obj = layer.objects.active
    if obj is None or obj.mode != 'EDIT':
        yield
        return
    editing = [o for o in layer.objects if o.mode == 'EDIT']
    bpy.ops.object.mode_set(mode='OBJECT')
    try:
        yield
    finally:
        selected = [o for o in layer.objects if o.select_get()]
        for o in selected:
            o.select_set(False)
        for o in editing:
            if o.name in layer.objects:
                o.select_set(True)
        layer.objects.active = obj
        bpy.ops.object.mode_set(mode='EDIT')
        for o in layer.objects:
            o.select_set(o in selected)


def mirror_axes(obj, V):
    """The axes of a Mirror modifier that closes the base mesh into what the user sees: the first
    modifier shown, mirroring in the object's own space (no mirror object) with Merge on, without
    Bisect, the mesh on one side of each plane. ([(axis, merge distance)], None), or ([], why not)
    (the base mesh is processed as it is; '' without a Mirror)."""
    mods = [m for m in obj.modifiers if m.show_viewport]
    mirrors = [m for m in mods if m.type == 'MIRROR']
    if not mirrors:
        return [], ""
    m = mirrors[0]
    why = ("it is not the first modifier" if mods[0] != m else "it has a mirror object" if m.mirror_object
           else "Merge is off" if not m.use_mirror_merge else "Bisect is on" if any(m.use_bisect_axis) else None)
    if why:
        return [], why
    axes = []
    for k in range(3):
        if not m.use_axis[k]:
            continue
        x = V[:, k]
        tol = 0.5 * m.merge_threshold  # Blender merges a vertex with its mirror image within the threshold
        if not ((x >= -tol).all() or (x <= tol).all()):
            return [], "the mesh is on both sides of its plane"
        axes.append((k, tol))
    return axes, None


def on_mirror_planes(V, V0, axes):
    """Vertices of the base mesh (V's first rows) that were on a mirror plane stay exactly there."""
    for k, tol in axes:
        seam = np.flatnonzero(np.abs(V0[:, k]) <= tol)
        V[seam, k] = V0[seam, k]
    return V


def mirror_plane_bits(V, axes):
    """Per vertex, bit k set when it lies on the mirror plane of axis k (``mirror_axes``'s axes)."""
    bits = np.zeros(len(V), np.int32)
    for k, tol in axes:
        bits[np.abs(V[:, k]) <= tol] |= 1 << k
    return bits


def mesh_has_modifiers(obj):
    """True if the object's displayed mesh differs from its datablock's
    because of enabled modifiers."""
    return any(m.show_viewport or m.show_render for m in obj.modifiers)


# Generic attribute types that operators making new vertices or faces carry onto them, read and
# written in bulk: data_type -> (foreach key, components, dtype). Integers and booleans are copied
# from one source, the others blended. (Blender 3.4's bmesh reaches neither booleans nor 2D vectors.)
ATTRIBUTE_TYPES = {
    'FLOAT': ("value", 1, np.float32), 'FLOAT2': ("vector", 2, np.float32),
    'FLOAT_VECTOR': ("vector", 3, np.float32), 'FLOAT_COLOR': ("color", 4, np.float32),
    # bytes as stored (sRGB): `color` would convert them to linear and back
    'BYTE_COLOR': ("color_srgb", 4, np.float32),
    'INT': ("value", 1, np.int32), 'INT8': ("value", 1, np.int32), 'BOOLEAN': ("value", 1, bool),
}


# Blender's own data stored as attributes (3.4: material_index; 4.x: more; 5.x: uv_seam, the seam
# flag), which operators set themselves or which bmesh writes as flags and may drop as attributes.
BUILTIN_ATTRIBUTES = {"position", "material_index", "sharp_face", "sharp_edge", "crease_vert", "crease_edge",
                      "bevel_weight_vert", "bevel_weight_edge", "uv_seam"}


def _carried(att, domain):
    """Whether new elements of ``domain`` should take attribute ``att`` from their sources: the user's
    generic attributes, not Blender's internal ('.select_vert') or built-in ones."""
    return (att.domain == domain and att.data_type in ATTRIBUTE_TYPES and not att.name.startswith(".")
            and att.name not in BUILTIN_ATTRIBUTES)


def _read_attribute(att):
    key, k, dtype = ATTRIBUTE_TYPES[att.data_type]
    a = np.empty(k * len(att.data), dtype)
    att.data.foreach_get(key, a)
    return a.reshape(-1, k)


def _vertex_references(mesh):
    """(children parented to vertices of objects using ``mesh``, their Hook modifiers with vertex
    indices)."""
    users = {o for o in bpy.data.objects if o.data == mesh}
    children = [o for o in bpy.data.objects if o.parent in users and o.parent_type in {'VERTEX', 'VERTEX_3'}]
    hooks = [m for o in users for m in o.modifiers if m.type == 'HOOK' and len(m.vertex_indices)]
    return children, hooks


def has_vertex_references(mesh):
    """Whether a renumbering of ``mesh``'s vertices needs :func:`remap_vertex_references`."""
    return any(_vertex_references(mesh))


def remap_vertex_references(mesh, new_index, fallback=None):
    """After a renumbering of ``mesh``'s vertices written outside Edit mode (``new_index[old]``, -1
    for a removed vertex), the vertex parents of children and the Hook modifiers of every object
    using the mesh follow it, as Blender's remap on leaving Edit mode does. ``fallback(old) -> new``
    places references to removed vertices (without it hooks drop them and parents keep theirs)."""
    n = len(new_index)

    def new(i):
        if not 0 <= i < n:
            return i
        j = int(new_index[i])
        return j if j >= 0 or fallback is None else int(fallback(i))

    children, hooks = _vertex_references(mesh)
    for o in children:
        o.parent_vertices = [j if (j := new(i)) >= 0 else i for i in o.parent_vertices]
    for m in hooks:
        m.vertex_indices_set(sorted({new(i) for i in m.vertex_indices} - {-1}))


def read_attributes(mesh, domain):
    """[(name, (n, k) values)] of the generic attributes of ``domain`` (colours included) that new
    elements an operator makes should take from the ones they are made from: read before the mesh
    changes."""
    return [(att.name, _read_attribute(att)) for att in mesh.attributes if _carried(att, domain)]


def blend_attributes(values, idx, w):
    """Values of new elements from ``read_attributes``: new element i gets sum_k w[i, k] *
    values[idx[i, k]] (integers and booleans: the heaviest source's)."""
    idx, w = np.asarray(idx), np.asarray(w, dtype=float)
    heavy = idx[np.arange(len(idx)), w.argmax(1)]
    return [(name, a[heavy] if a.dtype.kind in "ib" else np.einsum("nk,nkd->nd", w, a[idx].astype(float)))
            for name, a in values]


def write_attributes(mesh, rows, values):
    """Writes values [(name, (len(rows), k))] at elements ``rows`` of the changed mesh."""
    for name, v in values:
        att = mesh.attributes[name]
        a = _read_attribute(att)
        a[rows] = v
        att.data.foreach_set(ATTRIBUTE_TYPES[att.data_type][0], a.ravel())


def read_vertex_groups(obj):
    """The object's vertex groups (names, lock flags, the active one) and weights as (vertex, group,
    weight) arrays, or None without groups; for an operator that rebuilds the geometry, which
    clears them. A Python loop over the vertices: Blender has no bulk access to the weights."""
    groups = obj.vertex_groups
    if not len(groups):
        return None
    v, g, w = [], [], []
    for vert in obj.data.vertices:
        for e in vert.groups:
            v.append(vert.index)
            g.append(e.group)
            w.append(e.weight)
    return {"names": [x.name for x in groups], "locks": [x.lock_weight for x in groups],
            "active": groups.active_index, "vertex": np.array(v, np.int64), "group": np.array(g, np.int64),
            "weight": np.array(w, float)}


def write_vertex_groups(obj, groups, idx, w):
    """Writes ``read_vertex_groups``' groups on the object's rebuilt mesh: output vertex i gets
    sum_k w[i, k] * (weights of input vertex idx[i, k]), as blend_attributes blends."""
    for name, lock in zip(groups["names"], groups["locks"]):
        obj.vertex_groups.new(name=name).lock_weight = lock
    obj.vertex_groups.active_index = groups["active"]
    vert, group, weight, counted = _blend_group_weights(idx, w, groups["vertex"], groups["group"],
                                                        groups["weight"], len(groups["names"]))
    # A member with weight 0 stays one where a source counts (not for a zero barycentric).
    vert, group, weight = vert[counted], group[counted], weight[counted]
    bm = bmesh.new()
    try:
        bm.from_mesh(obj.data)
        deform = bm.verts.layers.deform.verify()
        bm.verts.ensure_lookup_table()
        for i, g, x in zip(vert.tolist(), group.tolist(), weight.tolist()):
            bm.verts[i][deform][g] = x
        bm.to_mesh(obj.data)
    finally:
        bm.free()


def _blend_group_weights(idx, w, ev, eg, ew, n_groups):
    """Vertex-group weights blended from sources given as (vertex, group, weight) entries: output
    vertex i gets sum_k w[i, k] * (weights of source idx[i, k]). Returns (vertex, group, weight,
    counted) per output membership, counted where some source with a nonzero w is a member."""
    idx, w = np.asarray(idx), np.asarray(w, dtype=float)
    o, src, w = np.repeat(np.arange(len(idx)), idx.shape[1]), idx.ravel(), w.ravel()
    order = np.argsort(ev, kind="stable")
    ev, eg, ew = ev[order], eg[order], ew[order]
    start = np.searchsorted(ev, np.arange(int(src.max(initial=-1)) + 2))
    count = start[src + 1] - start[src]
    at = ranges(start[src], count)
    key = np.repeat(o, count) * n_groups + eg[at]
    key, inv = np.unique(key, return_inverse=True)
    weight = np.bincount(inv, np.repeat(w, count) * ew[at])
    counted = np.bincount(inv, np.repeat(w, count)) > 0
    vert, group = np.divmod(key, n_groups)
    return vert, group, weight, counted


def blend_vertex_groups(new_verts, src_verts, idx, w, deform):
    """Vertex-group weights of new bmesh vertices (``deform``: the bmesh deform layer) blended from
    existing ones: new vertex i gets sum_k w[i, k] * weights(src_verts[idx[i, k]]). Read all at
    once, so the sources must still exist. (No bulk access to vertex groups: bmesh per vertex.)"""
    if deform is None or not len(new_verts) or not len(src_verts):
        return
    idx, w = np.asarray(idx), np.asarray(w, dtype=float)
    # Only the sources some new vertex reads are read (each one is a Python access).
    used, idx = np.unique(idx, return_inverse=True)
    idx = idx.reshape(w.shape)
    entries = [(j, g, x) for j, i in enumerate(used.tolist()) for g, x in src_verts[i][deform].items()]
    if not entries:
        return
    ev, eg, ew = (np.array(c) for c in zip(*entries))
    vert, group, weight, _counted = _blend_group_weights(idx, w, ev, eg, ew, int(eg.max()) + 1)
    for i, g, x in zip(vert.tolist(), group.tolist(), weight.tolist()):
        if x > 0:
            new_verts[i][deform][g] = x


def corner_layers(mesh):
    """((kind, name), width) of the corner data that faces an operator makes should take from the
    faces they replace: UV maps ('uv') and the generic corner attributes, colours included
    ('attr')."""
    out = [(("uv", uv.name), 2) for uv in mesh.uv_layers]
    uvs = {u.name for u in mesh.uv_layers}  # Blender 3.5+ lists UV maps among the attributes too
    out += [(("attr", att.name), ATTRIBUTE_TYPES[att.data_type][1]) for att in mesh.attributes
            if _carried(att, 'CORNER') and att.name not in uvs]
    return out


def _corner_data(mesh, kind, name):
    """(data collection, foreach key, dtype) of a corner layer named as corner_layers names it."""
    if kind == "uv":
        return mesh.uv_layers[name].data, "uv", np.float32
    att = mesh.attributes[name]
    key, _k, dtype = ATTRIBUTE_TYPES[att.data_type]
    return att.data, key, dtype


def read_corners(mesh, kind, name, width):
    """(loops, width) values of one corner layer (see corner_layers)."""
    data, key, dtype = _corner_data(mesh, kind, name)
    a = np.empty(width * len(mesh.loops), dtype)
    data.foreach_get(key, a)
    return a.reshape(-1, width)


def new_face_loops(mesh, polys, want):
    """(m, 3) loops of the new triangles ``polys`` whose corners are the vertices ``want`` (m, 3),
    in that order (each loop's vertex says which corner it is)."""
    start = get_array(mesh.polygons, "loop_start", np.int32)[polys]
    got = get_array(mesh.loops, "vertex_index", np.int32)[start[:, None] + np.arange(3)]
    pos = np.argmax(got[:, None, :] == want[:, :, None], axis=2)  # corner j is loop pos[t, j] of face t
    if not np.array_equal(np.take_along_axis(got, pos, 1), want):
        raise RuntimeError("the new faces' corners were not found")
    return start[:, None] + pos


def write_corners(mesh, loops, corner):
    """Writes corner values ((kind, name), (m, 3[, k])) at ``loops`` (m, 3), one foreach_set per
    layer: a Python loop per face and corner took half of a 100K-vertex Remesh."""
    loops = np.asarray(loops).ravel()
    for (kind, name), values in corner:
        k = values.shape[2] if values.ndim == 3 else 1
        a = read_corners(mesh, kind, name, k)
        a[loops] = values.reshape(-1, k)
        data, key, _dtype = _corner_data(mesh, kind, name)
        data.foreach_set(key, a.ravel())
