"""Blender version differences, in one place.

The add-on runs in Blender 3.4 (Debian bookworm) through 5.x. Where the Python API differs between
versions, operators and tests call a function here; each is chosen by feature (the RNA property or
method that exists) or by ``bpy.app.version``, and tests/blender/test_compat.py exercises it in the
lane where it matters (scripts/lanes.sh: 3.4, 4.3, 5.x). Nothing else in the add-on tests for a
version.

What differs, by version:
- 3.5: a UV map's selection and pins become bool layers beside it, made when a flag is first set;
  making one moves the mesh's layers, so a UV map object held across it is invalid (4.x writes
  through it into freed memory).
- 4.0: edge creases and bevel weights become the attributes crease_edge / bevel_weight_edge (and
  vertex ones crease_vert / bevel_weight_vert; 3.4 keeps vertex creases in a crease layer);
  node groups declare sockets through ``interface``; ``is_modifier`` lists a group in the modifier.
- 4.1: corner normals are always available (``Mesh.corner_normals``); ``use_auto_smooth`` and
  ``calc_normals_split`` are gone.
- 5.0: materials always use nodes (``Material.use_nodes`` is deprecated); the UV selection moves
  from the UV map (MeshUVLoop.select*, the map's vertex_selection / edge_selection layers,
  BMLoopUV.select*) to the mesh (``.uv_select_vert`` / ``.uv_select_edge`` / ``.uv_select_face``
  attributes, BMLoop.uv_select_vert / uv_select_edge, BMFace.uv_select).
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
    # 3.4: the UV map's corner flags (3.5-4.x keep MeshUVLoop.select, but setting it makes a layer,
    # which invalidates ``layer`` for the next part)
    if "select" in bpy.types.MeshUVLoop.bl_rna.properties and not hasattr(layer, "vertex_selection"):
        return [(layer.data, "select", n), (layer.data, "select_edge", n)]
    if hasattr(layer, "vertex_selection"):  # 3.5-4.x: bool layers beside the UVs
        props = ("vertex_selection", "edge_selection")
        if create:
            _ensure_uv_bool_layers(mesh, props)
            layer = mesh.uv_layers.active
        return [(getattr(layer, prop), "value", n) if _has_uv_bool_layer(mesh, prop) else (None, None, n)
                for prop in props]
    parts = []
    for name, domain, size in ((".uv_select_vert", 'CORNER', n), (".uv_select_edge", 'CORNER', n),
                               (".uv_select_face", 'FACE', len(mesh.polygons))):  # 5.0+: the mesh's
        att = mesh.attributes.get(name)
        if att is None and create:
            att = mesh.attributes.new(name, 'BOOLEAN', domain)
        parts.append((att.data, "value", size) if att is not None else (None, None, size))
    return parts


# 3.5+: the active UV map's bool layers by property of the map, and the attribute name prefix.
_UV_BOOL_LAYERS = {"vertex_selection": ".vs.", "edge_selection": ".es.", "pin": ".pn."}


def _has_uv_bool_layer(mesh, prop):
    """3.5+: whether the active UV map has its bool layer ``prop`` (a key of _UV_BOOL_LAYERS). Not
    by the length of the map's collection: 4.x gives every corner's count for a missing layer, and
    reading or writing it does nothing."""
    return mesh.attributes.get(_UV_BOOL_LAYERS[prop] + mesh.uv_layers.active.name) is not None


def _ensure_uv_bool_layers(mesh, props):
    """3.5+: makes the active UV map's bool layers ``props`` (keys of _UV_BOOL_LAYERS) that it lacks
    (Blender makes them when a flag is first set). Adding a layer moves the mesh's layers: a UV map
    (MeshUVLoopLayer) or one of its collections taken before points at freed memory afterwards (4.x
    writes through it and corrupts the heap), so callers take the UV map again."""
    for prop in props:
        if not _has_uv_bool_layer(mesh, prop):
            mesh.attributes.new(_UV_BOOL_LAYERS[prop] + mesh.uv_layers.active.name, 'BOOLEAN', 'CORNER')


def uv_pins(mesh):
    """Object mode: the pins of the active UV map's corners (bool array, all False when nothing was
    ever pinned), or None without a UV map."""
    layer = mesh.uv_layers.active
    if layer is None:
        return None
    pins = np.zeros(len(mesh.loops), bool)
    if not hasattr(layer, "pin"):  # 3.4: the UV map's corner flags
        layer.data.foreach_get("pin_uv", pins)
    elif _has_uv_bool_layer(mesh, "pin"):  # 3.5+: a bool layer beside the UVs, made when first pinned
        layer.pin.foreach_get("value", pins)
    return pins


def set_uv_pins(mesh, pins):
    """Object mode: sets the pins (bool per corner) of the active UV map. Never set them through a
    UV map held across the call (``layer.data[i].pin_uv = True`` adds the pin layer in 3.5+ and
    leaves ``layer`` pointing at freed memory)."""
    pins = np.ascontiguousarray(pins, dtype=bool)
    if not hasattr(mesh.uv_layers.active, "pin"):  # 3.4
        mesh.uv_layers.active.data.foreach_set("pin_uv", pins)
        return
    _ensure_uv_bool_layers(mesh, ("pin",))
    mesh.uv_layers.active.pin.foreach_set("value", pins)


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


def bm_uv_select_state(bm, uv_layer):
    """Edit mode: what turning synced UV selection on or off may rewrite in edit-mesh ``bm``, for
    :func:`bm_set_uv_select_state`. 5.0+: every loop's UV flags (set from the mesh selection, or
    flushed) and whether the UV selection is in use (``BMesh.uv_select_sync_valid``); a Python pass
    over all loops. None before 5.0, where the toggle leaves the UV flags alone."""
    if not hasattr(bmesh.types.BMesh, "uv_select_sync_valid"):
        return None
    loops = [l for f in bm.faces for l in f.loops]  # valid while ``bm``'s Python object lives
    return loops, bm_uv_flags(loops, uv_layer), bm.uv_select_sync_valid


def bm_set_uv_select_state(bm, uv_layer, state):
    """Puts back what :func:`bm_uv_select_state` returned (None: nothing to do)."""
    if state is None:
        return
    loops, flags, valid = state
    bm_set_uv_flags(loops, uv_layer, flags)
    bm.uv_select_sync_valid = valid


def pack_islands(margin):
    """Blender's UV packer on the selected UVs, with 3.4's packing (bounding boxes) in every version."""
    kw = {}
    if "shape_method" in bpy.ops.uv.pack_islands.get_rna_type().properties:  # 3.6+
        kw["shape_method"] = 'AABB'
    bpy.ops.uv.pack_islands(margin=margin, **kw)


# --- properties -----------------------------------------------------------------------------------
# Options of an operator's file path property: 5.x warns when a "//" (blend-relative) path is set
# on one that does not declare PATH_SUPPORTS_BLEND_RELATIVE, which earlier versions do not know
# (registering the operator fails there).
FILE_PATH_OPTIONS = ({'PATH_SUPPORTS_BLEND_RELATIVE'}
                     if "is_path_supports_blend_relative" in bpy.types.Property.bl_rna.properties else {'ANIMATABLE'})


# --- materials ----------------------------------------------------------------------------------
def use_shader_nodes(mat):
    """Gives material ``mat`` its shader node tree (5.0+: every material has one; setting
    ``use_nodes`` is deprecated there)."""
    if VERSION < (5, 0, 0):
        mat.use_nodes = True


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
