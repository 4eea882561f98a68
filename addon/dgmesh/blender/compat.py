"""Blender version differences, in one place.

The add-on runs in Blender 3.4 (Debian bookworm) through 5.x. Where the Python API differs between
versions, operators and tests call a function here; each is chosen by feature (the RNA property or
method that exists) or by ``bpy.app.version``, and tests/blender/test_compat.py exercises it in the
lane where it matters (scripts/lanes.sh: 3.4, 4.3, 5.x). Nothing else in the add-on tests for a
version.

What differs, by version:
- 4.0: edge creases and bevel weights become the attributes crease_edge / bevel_weight_edge (and
  vertex ones crease_vert / bevel_weight_vert; 3.4 keeps vertex creases in a crease layer);
  node groups declare sockets through ``interface``; ``is_modifier`` lists a group in the modifier.
- 4.1: corner normals are always available (``Mesh.corner_normals``); ``use_auto_smooth`` and
  ``calc_normals_split`` are gone.
- 5.0: the UV selection moves from the UV map (MeshUVLoop.select*, the map's vertex_selection /
  edge_selection layers, BMLoopUV.select*) to the mesh (``.uv_select_vert`` / ``.uv_select_edge``
  corner attributes, BMLoop.uv_select_vert / uv_select_edge).
"""

import bmesh
import bpy
import numpy as np

VERSION = bpy.app.version


def _writable(struct, prop):
    """Whether RNA struct (a bpy.types class or an instance) has ``prop``, writable."""
    rna = struct.bl_rna.properties.get(prop)
    return rna is not None and not rna.is_readonly


# --- per-element values that became attributes --------------------------------------------------
# Attribute name -> (mesh collection, RNA struct, property) of the property it replaced.
_ELEMENT_PROPERTIES = {
    "crease_edge": ("edges", bpy.types.MeshEdge, "crease"),
    "bevel_weight_edge": ("edges", bpy.types.MeshEdge, "bevel_weight"),
    "bevel_weight_vert": ("vertices", bpy.types.MeshVertex, "bevel_weight"),
    "sharp_edge": ("edges", bpy.types.MeshEdge, "use_edge_sharp"),
}


def _vertex_crease_layer(mesh):
    """3.4-3.6: the vertex crease layer (None when the mesh has none); 4.0+ uses crease_vert."""
    if VERSION >= (4, 0, 0):
        return None
    return mesh.vertex_creases[0] if len(mesh.vertex_creases) else None


def element_values(mesh, name):
    """Values of a built-in per-element layer, as numpy (float32; bool for sharp_edge), or None when
    the mesh does not have it: ``name`` is the 4.x attribute name (crease_vert, crease_edge,
    bevel_weight_vert, bevel_weight_edge, sharp_edge), read from the property it replaced in older
    versions."""
    dtype = bool if name == "sharp_edge" else np.float32
    if name == "crease_vert" and VERSION < (4, 0, 0):
        layer = _vertex_crease_layer(mesh)
        coll, key = (layer.data, "value") if layer is not None else (None, None)
    elif name in _ELEMENT_PROPERTIES and _writable(_ELEMENT_PROPERTIES[name][1], _ELEMENT_PROPERTIES[name][2]):
        coll_name, _struct, key = _ELEMENT_PROPERTIES[name]
        coll = getattr(mesh, coll_name)
    else:
        att = mesh.attributes.get(name)
        coll, key = (att.data, "value") if att is not None else (None, None)
    if coll is None:
        return None
    out = np.empty(len(coll), dtype)
    coll.foreach_get(key, out)
    return out


def set_element_values(mesh, name, values):
    """Writes a built-in per-element layer (``element_values``' names), making it where needed."""
    dtype = bool if name == "sharp_edge" else np.float32
    values = np.ascontiguousarray(values, dtype=dtype)
    if name == "crease_vert" and VERSION < (4, 0, 0):
        if _vertex_crease_layer(mesh) is None:
            import bmesh  # 3.4: only bmesh makes the layer

            bm = bmesh.new()
            try:
                bm.from_mesh(mesh)
                bm.verts.layers.crease.verify()
                bm.to_mesh(mesh)
            finally:
                bm.free()
        _vertex_crease_layer(mesh).data.foreach_set("value", values)
        return
    entry = _ELEMENT_PROPERTIES.get(name)
    if entry is not None and _writable(entry[1], entry[2]):
        getattr(mesh, entry[0]).foreach_set(entry[2], values)
        return
    domain = 'POINT' if name.endswith("_vert") else 'EDGE'
    att = mesh.attributes.get(name)
    if att is None:
        att = mesh.attributes.new(name, 'BOOLEAN' if dtype is bool else 'FLOAT', domain)
    att.data.foreach_set("value", values)


def set_loop_totals(mesh, totals):
    """After ``mesh.polygons.add`` and ``loop_start``: each polygon's corner count (3.x stores it;
    4.0+ derives it from loop_start and makes it read-only)."""
    if _writable(bpy.types.MeshPolygon, "loop_total"):
        mesh.polygons.foreach_set("loop_total", np.ascontiguousarray(totals, dtype=np.int32))


def set_color_names(colors, active, render):
    """Makes colour attributes ``active`` and ``render`` (names) the active and the render colour."""
    if _writable(colors, "active_color_name"):  # 4.x: the documented way
        colors.active_color_name = active
        colors.default_color_name = render
    else:  # 3.4: the *_name properties are read-only; use pointer and index
        colors.active_color = colors[active]
        colors.render_color_index = [a.name for a in colors].index(render)


# --- normals -------------------------------------------------------------------------------------
def corner_normals(mesh):
    """(n_corners, 3) float32 corner (split) normals, custom normals included."""
    out = np.empty(3 * len(mesh.loops), np.float32)
    if hasattr(mesh, "corner_normals"):  # 4.1+
        mesh.corner_normals.foreach_get("vector", out)
    else:
        mesh.calc_normals_split()
        mesh.loops.foreach_get("normal", out)
    return out.reshape(-1, 3)


def set_custom_normals(mesh, normals):
    """Sets custom split normals per corner ((n_corners, 3) unit vectors)."""
    if hasattr(mesh, "use_auto_smooth"):  # before 4.1 custom normals need auto smooth
        mesh.use_auto_smooth = True
    mesh.normals_split_custom_set(np.asarray(normals, dtype=np.float32).reshape(-1, 3))


# --- UV selection ---------------------------------------------------------------------------------
def uv_selection(mesh):
    """Object mode: the UV selection of the active UV map's corners (vertex and edge flags per
    corner; in 5.0+ also per face), bool arrays, or None without a UV map."""
    if mesh.uv_layers.active is None:
        return None
    saved = []
    for coll, key, n in _uv_selection_parts(mesh):
        sel = np.zeros(n, bool)
        if coll is not None and len(coll) == n:
            coll.foreach_get(key, sel)
        saved.append(sel)
    return saved


def set_uv_selection(mesh, selection):
    """Object mode: restores what :func:`uv_selection` returned (None: nothing to do)."""
    if selection is None or mesh.uv_layers.active is None:
        return
    for (coll, key, _n), sel in zip(_uv_selection_parts(mesh, create=True), selection):
        if coll is not None and len(coll) == len(sel):
            coll.foreach_set(key, sel)


def _uv_selection_parts(mesh, create=False):
    """[(collection, key, length)] holding the UV selection."""
    layer, n = mesh.uv_layers.active, len(mesh.loops)
    if "select" in bpy.types.MeshUVLoop.bl_rna.properties:  # 3.4: the UV map's corner flags
        return [(layer.data, "select", n), (layer.data, "select_edge", n)]
    if hasattr(layer, "vertex_selection"):  # 3.5-4.x: bool layers beside the UVs
        return [(layer.vertex_selection, "value", n), (layer.edge_selection, "value", n)]
    parts = []
    for name, domain, size in ((".uv_select_vert", 'CORNER', n), (".uv_select_edge", 'CORNER', n),
                               (".uv_select_face", 'FACE', len(mesh.polygons))):  # 5.0+: the mesh's
        att = mesh.attributes.get(name)
        if att is None and create:
            att = mesh.attributes.new(name, 'BOOLEAN', domain)
        parts.append((att.data, "value", size) if att is not None else (None, None, size))
    return parts


def bm_uv_flags(loops, uv_layer):
    """Edit mode (bmesh loops of the active UV map ``uv_layer``): their UV selection, as
    :func:`bm_set_uv_flags` takes it back."""
    if hasattr(bmesh.types.BMLoop, "uv_select_vert"):  # 5.0+: the mesh's, faces included
        return ([l.uv_select_vert for l in loops], [l.uv_select_edge for l in loops],
                [l.face.uv_select for l in loops])
    data = [l[uv_layer] for l in loops]
    return [d.select for d in data], [d.select_edge for d in data]


def bm_set_uv_flags(loops, uv_layer, flags):
    """Sets the loops' UV selection: one bool for all, or what :func:`bm_uv_flags` returned."""
    if isinstance(flags, bool):
        flags = ([flags] * len(loops),) * 3
    if hasattr(bmesh.types.BMLoop, "uv_select_vert"):  # 5.0+
        for l, v, e, f in zip(loops, *flags):
            l.uv_select_vert, l.uv_select_edge = v, e
            l.face.uv_select = f
        return
    for l, v, e in zip(loops, flags[0], flags[1]):
        d = l[uv_layer]
        d.select, d.select_edge = v, e


def pack_islands(margin):
    """Blender's UV packer on the selected UVs, with 3.4's packing (bounding boxes) in every version."""
    kw = {}
    if "shape_method" in bpy.ops.uv.pack_islands.get_rna_type().properties:  # 3.6+
        kw["shape_method"] = 'AABB'
    bpy.ops.uv.pack_islands(margin=margin, **kw)


# --- node groups and modifiers --------------------------------------------------------------------
def new_geometry_node_group(name):
    """A geometry node group with one Geometry input and output, listed as a modifier group."""
    ng = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    if hasattr(ng, "interface"):  # 4.0+
        ng.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
        ng.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    else:
        ng.inputs.new('NodeSocketGeometry', "Geometry")
        ng.outputs.new('NodeSocketGeometry', "Geometry")
    if hasattr(ng, "is_modifier"):  # 4.0+: listed in the modifier's node group menu
        ng.is_modifier = True
    return ng


def move_modifier(obj, mod, index):
    """Moves modifier ``mod`` of ``obj`` to position ``index``."""
    idx = [m.name for m in obj.modifiers].index(mod.name)
    if idx == index:
        return
    if hasattr(obj.modifiers, "move"):  # 3.5+
        obj.modifiers.move(idx, index)
        return
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=index)
