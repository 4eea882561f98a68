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

What happens to the arrays between reading and writing (n-gon triangle repair, edge lookups,
attribute blending, ...) is plain numpy in ``dgmesh.polymesh``.
"""

from contextlib import contextmanager

import bmesh
import bpy
import numpy as np

from ..polymesh import MeshArrays, blend_group_weights
from . import compat


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


def kd_nearest(Q, P, k):
    """(len(P), k) indices of the k points of Q (n, 3) nearest to each point of P (m, 3), nearest
    first, by Blender's kd-tree (``polymesh.nearest_sources``' ``knn``). A Python loop over the
    points: mathutils has no bulk query."""
    from mathutils.kdtree import KDTree
    tree = KDTree(len(Q))
    for i, q in enumerate(Q.tolist()):
        tree.insert(q, i)
    tree.balance()
    return np.array([[i for _, i, _ in tree.find_n(p, k)] for p in P.tolist()], dtype=np.int64)


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
    sum_k w[i, k] * (weights of input vertex idx[i, k]), as polymesh.blend_attributes blends."""
    for name, lock in zip(groups["names"], groups["locks"]):
        obj.vertex_groups.new(name=name).lock_weight = lock
    obj.vertex_groups.active_index = groups["active"]
    vert, group, weight, counted = blend_group_weights(idx, w, groups["vertex"], groups["group"],
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
    vert, group, weight, _counted = blend_group_weights(idx, w, ev, eg, ew, int(eg.max()) + 1)
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
