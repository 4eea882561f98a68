"""Operators of thesis chapter 4: crest lines, feature-sensitive decimation, segmentation.

All three work on the active mesh object (original data, modifiers ignored), compute everything
before writing anything, and turn errors into ERROR reports with the mesh left untouched.
Crest-line fitting is cached per mesh content and ``rings``, so redo-panel changes of the
threshold or the marking flags only re-filter the traced lines.
"""

import colorsys
import hashlib

import bpy
import numpy as np
from bpy.props import BoolProperty, FloatProperty, IntProperty

from .. import colors
from . import bridge
from .prefs import api

ATTR_RIDGE = "dg_ridge"
ATTR_VALLEY = "dg_valley"
ATTR_SEGMENT = "dg_segment"
ATTR_SEGMENT_COLOR = "dg_segment_color"
RIDGE_RGB = (0.1, 0.25, 1.0)   # thesis figures: ridges blue ...
VALLEY_RGB = (1.0, 0.1, 0.1)   # ... valleys red

_CACHE = {}  # (mesh key, rings) -> unfiltered CrestLines; a few entries only
_CACHE_SIZE = 4


def _poll_fail(cls, message):
    if hasattr(cls, "poll_message_set"):
        cls.poll_message_set(message)
    return False


def _active_mesh(context):
    obj = context.active_object
    return obj if obj is not None and obj.type == 'MESH' else None


def _poll_mesh(cls, context):
    if context.mode not in {'OBJECT', 'EDIT_MESH'}:
        return _poll_fail(cls, "Only available in Object mode and mesh Edit mode")
    if _active_mesh(context) is None:
        return _poll_fail(cls, "The active object must be a mesh")
    return True


class _Progress:
    """Window-manager progress (only when there is a window) fed by native callbacks."""

    def __init__(self, context, lo=0.0, hi=1.0):
        self.wm = context.window_manager if context.window is not None else None
        self.lo, self.hi = lo, hi

    def __enter__(self):
        if self.wm is not None:
            self.wm.progress_begin(0, 1000)
        return self

    def __call__(self, fraction):
        if self.wm is not None:
            self.wm.progress_update(int(1000 * (self.lo + (self.hi - self.lo) * fraction)))
        return True

    def __exit__(self, *exc):
        if self.wm is not None:
            self.wm.progress_end()
        return False


def _mesh_key(arrays):
    h = hashlib.blake2b(digest_size=16)
    h.update(np.ascontiguousarray(arrays.V).tobytes())
    h.update(np.ascontiguousarray(arrays.F).tobytes())
    return h.hexdigest()


def cached_crest_lines(arrays, rings, progress=None):
    """Every traced line (threshold 0) of the mesh, from the cache when the mesh is unchanged."""
    dg = api()
    key = (_mesh_key(arrays), int(rings))
    lines = _CACHE.get(key)
    if lines is None:
        lines = dg.crest_lines(arrays.V, arrays.F, rings=rings, threshold=0.0, progress=progress)
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = lines
    return lines


def _edge_lookup(edges, n_vertices):
    keys = np.minimum(edges[:, 0], edges[:, 1]).astype(np.int64) * n_vertices + np.maximum(edges[:, 0], edges[:, 1])
    order = np.argsort(keys)
    return keys[order], order


def _find_edges(pairs, lookup, n_vertices):
    """Mesh edge index of each vertex pair, -1 when the pair is not a real edge."""
    skeys, order = lookup
    q = np.minimum(pairs[:, 0], pairs[:, 1]).astype(np.int64) * n_vertices + np.maximum(pairs[:, 0], pairs[:, 1])
    pos = np.clip(np.searchsorted(skeys, q), 0, max(len(skeys) - 1, 0))
    found = len(skeys) > 0
    hit = (skeys[pos] == q) if found else np.zeros(len(q), bool)
    return np.where(hit, order[pos] if found else -1, -1)


def _route(a, b, adjacency, max_depth=4):
    """Shortest path of real edges between vertices a and b (breadth first, a few steps)."""
    prev = {a: None}
    frontier = [a]
    for _ in range(max_depth):
        nxt = []
        for v in frontier:
            for w in adjacency(v):
                if w in prev:
                    continue
                prev[w] = v
                if w == b:
                    path = [b]
                    while prev[path[-1]] is not None:
                        path.append(prev[path[-1]])
                    return path[::-1]
                nxt.append(w)
        frontier = nxt
    return None


def crest_edges(lines, arrays):
    """Boolean masks over the mesh's own edges following the ridges and the valleys.

    Points snap to the nearer end of their edge; consecutive snapped vertices are joined by the
    real (polygon) edge between them, or by a short path of real edges when they are joined by a
    triangulation diagonal of an n-gon or a gap jump.
    """
    dg = api()
    E = arrays.edges
    nv = len(arrays.V)
    ridge = np.zeros(len(E), bool)
    valley = np.zeros(len(E), bool)
    if len(lines) == 0 or len(E) == 0:
        return ridge, valley
    pairs, line = dg.crest.snap_to_vertices(lines, arrays.V, arrays.F)
    kind = lines.line_kind[line]
    lookup = _edge_lookup(E, nv)
    idx = _find_edges(pairs, lookup, nv)
    ridge[idx[(idx >= 0) & (kind == dg.crest.RIDGE)]] = True
    valley[idx[(idx >= 0) & (kind == dg.crest.VALLEY)]] = True
    missing = np.flatnonzero(idx < 0)
    if missing.size:
        # CSR adjacency of the real edges, for the few pairs that need routing.
        both = np.concatenate([E, E[:, ::-1]])
        order = np.argsort(both[:, 0], kind="stable")
        nbr = both[order, 1]
        start = np.searchsorted(both[order, 0], np.arange(nv + 1))
        adjacency = lambda v: nbr[start[v]:start[v + 1]].tolist()  # noqa: E731
        for i in missing.tolist():
            path = _route(int(pairs[i, 0]), int(pairs[i, 1]), adjacency)
            if path is None:
                continue
            steps = np.array([path[:-1], path[1:]]).T
            e = _find_edges(steps, lookup, nv)
            (ridge if kind[i] == dg.crest.RIDGE else valley)[e[e >= 0]] = True
    return ridge, valley


def _write_edge_bool(mesh, name, values):
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != 'BOOLEAN' or attr.domain != 'EDGE'):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        mesh.attributes.new(name, 'BOOLEAN', 'EDGE')
    mesh.attributes[name].data.foreach_set("value", np.ascontiguousarray(values, dtype=bool))


def _or_edge_flag(mesh, prop, mask):
    """Sets a boolean edge flag (seam, sharp) on the masked edges, keeping the existing ones."""
    n = len(mesh.edges)
    rna = bpy.types.MeshEdge.bl_rna.properties.get("use_edge_sharp")
    if prop == "sharp" and (rna is None or rna.is_readonly):
        # 4.1+: sharp edges are the generic attribute "sharp_edge".
        attr = mesh.attributes.get("sharp_edge")
        cur = np.zeros(n, bool)
        if attr is not None:
            attr.data.foreach_get("value", cur)
        _write_edge_bool(mesh, "sharp_edge", cur | mask)
        return
    key = "use_seam" if prop == "seam" else "use_edge_sharp"
    cur = np.zeros(n, bool)
    mesh.edges.foreach_get(key, cur)
    mesh.edges.foreach_set(key, cur | mask)


def _curve_object(context, obj, lines):
    """(Re)creates '<object> Crest Lines': one poly spline per line, ridges blue, valleys red."""
    name = f"{obj.name} Crest Lines"
    old = bpy.data.objects.get(name)
    if old is not None and old.type == 'CURVE':
        data = old.data
        bpy.data.objects.remove(old)
        if data.users == 0:
            bpy.data.curves.remove(data)
    curve = bpy.data.curves.new(name, 'CURVE')
    curve.dimensions = '3D'
    curve.bevel_depth = 0.0
    for label, rgb in (("dg_ridge", RIDGE_RGB), ("dg_valley", VALLEY_RGB)):
        mat = bpy.data.materials.get(label) or bpy.data.materials.new(label)
        mat.diffuse_color = (*rgb, 1.0)
        curve.materials.append(mat)
    for poly, kind in zip(lines.polylines, lines.line_kind.tolist()):
        spline = curve.splines.new('POLY')
        spline.points.add(len(poly) - 1)
        co = np.ones((len(poly), 4), dtype=np.float32)
        co[:, :3] = poly
        spline.points.foreach_set("co", co.ravel())
        spline.material_index = int(kind)
    cobj = bpy.data.objects.new(name, curve)
    cobj.matrix_world = obj.matrix_world.copy()
    for coll in obj.users_collection:
        coll.objects.link(cobj)
        break
    else:
        context.scene.collection.objects.link(cobj)
    return cobj


class DGMESH_OT_crest_lines(bpy.types.Operator):
    bl_idname = "dgmesh.crest_lines"
    bl_label = "Crest Lines"
    bl_description = (
        "Detect ridges and valleys (crest lines) of the active mesh and mark the edges that follow "
        "them as edge attributes dg_ridge / dg_valley (optionally seams, sharp edges and a curve object)"
    )
    bl_options = {'REGISTER', 'UNDO'}

    rings: IntProperty(name="Rings", description="Fitting neighbourhood (k-ring): larger ignores finer "
                       "features and gives smoother lines", default=1, min=1, max=4)
    threshold: FloatProperty(name="Threshold", description="Keep lines whose strength T (scale "
                             "independent, thesis eq. 4.10) is at least this", default=2.0, min=0.0,
                             soft_max=100.0)
    ridges: BoolProperty(name="Ridges", description="Convex crest lines", default=True)
    valleys: BoolProperty(name="Valleys", description="Concave crest lines", default=True)
    mark_seams: BoolProperty(name="Mark Seams", description="Also mark the edges as UV seams", default=False)
    mark_sharp: BoolProperty(name="Mark Sharp", description="Also mark the edges as sharp", default=False)
    create_curves: BoolProperty(name="Curve Object", description="Add a curve object with the exact "
                                "polylines (ridges blue, valleys red)", default=False)

    @classmethod
    def poll(cls, context):
        return _poll_mesh(cls, context)

    def execute(self, context):
        dg = api()
        obj = _active_mesh(context)
        if obj.data.library is not None:
            self.report({'ERROR'}, f"'{obj.name}': mesh data is linked from a library and cannot be changed")
            return {'CANCELLED'}
        try:
            arrays = bridge.read_object(obj, edges=True)
            with _Progress(context) as progress:
                lines = cached_crest_lines(arrays, self.rings, progress).filter(
                    self.threshold, self.ridges, self.valleys)
            ridge, valley = crest_edges(lines, arrays)
        except dg.MeshError as exc:
            self.report({'ERROR'}, f"Crest lines failed on '{obj.name}': {exc}")
            return {'CANCELLED'}
        except dg.Cancelled:
            self.report({'WARNING'}, "Crest lines cancelled; nothing changed")
            return {'CANCELLED'}
        with bridge.object_mode(context):
            mesh = obj.data
            _write_edge_bool(mesh, ATTR_RIDGE, ridge)
            _write_edge_bool(mesh, ATTR_VALLEY, valley)
            if self.mark_seams:
                _or_edge_flag(mesh, "seam", ridge | valley)
            if self.mark_sharp:
                _or_edge_flag(mesh, "sharp", ridge | valley)
            mesh.update()
        if self.create_curves and len(lines):
            _curve_object(context, obj, lines)
        n_r = int((lines.line_kind == dg.crest.RIDGE).sum())
        self.report({'INFO'}, (
            f"Crest lines on '{obj.name}': {len(lines)} lines ({n_r} ridges, {len(lines) - n_r} valleys), "
            f"total length {lines.total_length:.4g}; marked {int(ridge.sum())} ridge and "
            f"{int(valley.sum())} valley edges (threshold {self.threshold:g}, rings {self.rings})"))
        return {'FINISHED'}


def _replace_mesh(obj, V, F):
    """New mesh datablock with the given triangles for obj (the old one stays for undo)."""
    mesh = bpy.data.meshes.new(obj.data.name)
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(V, dtype=np.float32).ravel())
    mesh.loops.add(3 * len(F))
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(F, dtype=np.int32).ravel())
    mesh.polygons.add(len(F))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    if "loop_total" in bpy.types.MeshPolygon.bl_rna.properties and not \
            bpy.types.MeshPolygon.bl_rna.properties["loop_total"].is_readonly:
        mesh.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    mesh.validate(verbose=False)
    for mat in obj.data.materials:
        mesh.materials.append(mat)
    old = obj.data
    obj.data = mesh
    return old


class DGMESH_OT_decimate_features(bpy.types.Operator):
    bl_idname = "dgmesh.decimate_features"
    bl_label = "Feature Decimate"
    bl_description = (
        "Quadric decimation of the active mesh that keeps density near salient crest lines "
        "(thesis 4.8); the result is a new triangle mesh (other attributes are not carried over)"
    )
    bl_options = {'REGISTER', 'UNDO'}

    ratio: FloatProperty(name="Ratio", description="Fraction of triangles to keep", default=0.1, min=0.001,
                         max=1.0, subtype='FACTOR')
    feature_weight: FloatProperty(name="Feature Weight", description="eta of thesis eq. 4.12: 0 is plain "
                                  "quadric decimation, larger keeps more near crest lines", default=6.0,
                                  min=0.0, soft_max=10.0)
    rings: IntProperty(name="Rings", default=1, min=1, max=4)
    threshold: FloatProperty(name="Threshold", description="Crest line strength threshold", default=2.0,
                             min=0.0, soft_max=100.0)

    @classmethod
    def poll(cls, context):
        return _poll_mesh(cls, context)

    def execute(self, context):
        dg = api()
        obj = _active_mesh(context)
        if obj.data.library is not None:
            self.report({'ERROR'}, f"'{obj.name}': mesh data is linked from a library and cannot be changed")
            return {'CANCELLED'}
        try:
            arrays = bridge.read_object(obj, edges=True)
            target = max(4, int(round(self.ratio * len(arrays.F))))
            with _Progress(context) as progress:
                lines = None
                if self.feature_weight > 0:
                    lines = cached_crest_lines(arrays, self.rings).filter(self.threshold)
                V2, F2 = dg.decimate(arrays.V, arrays.F, target_faces=target, feature_weight=self.feature_weight,
                                     crest_lines=lines, progress=progress)
        except dg.MeshError as exc:
            self.report({'ERROR'}, f"Decimation failed on '{obj.name}': {exc}")
            return {'CANCELLED'}
        except dg.Cancelled:
            self.report({'WARNING'}, "Decimation cancelled; nothing changed")
            return {'CANCELLED'}
        with bridge.object_mode(context):
            _replace_mesh(obj, V2, F2)
        n_lines = 0 if lines is None else len(lines)
        self.report({'INFO'}, (f"Decimated '{obj.name}': {len(arrays.F)} -> {len(F2)} triangles "
                               f"(feature weight {self.feature_weight:g}, {n_lines} crest lines)"))
        return {'FINISHED'}


def _segment_colors(n):
    """n distinct linear RGBA colours (golden-ratio hue steps)."""
    hues = (np.arange(n) * 0.618033988749895) % 1.0
    rgb = np.array([colorsys.hsv_to_rgb(h, 0.55 + 0.3 * (i % 2), 0.9 - 0.15 * (i % 3 == 2))
                    for i, h in enumerate(hues)])
    out = np.ones((n, 4), dtype=np.float32)
    out[:, :3] = colors.srgb_to_linear(rgb)
    return out


class DGMESH_OT_segment(bpy.types.Operator):
    bl_idname = "dgmesh.segment"
    bl_label = "Segment"
    bl_description = (
        "Split the active mesh into nearly planar connected segments (variational shape approximation "
        "guided by crest lines, thesis 4.9): INT face attribute dg_segment, a colour per segment, "
        "optionally seams on segment borders"
    )
    bl_options = {'REGISTER', 'UNDO'}

    segments: IntProperty(name="Segments", default=25, min=1, soft_max=200)
    feature_weight: FloatProperty(name="Feature Weight", description="eta of thesis eq. 4.12: 0 is plain "
                                  "VSA, larger makes borders follow crest lines", default=2.0, min=0.0,
                                  soft_max=10.0)
    rings: IntProperty(name="Rings", default=1, min=1, max=4)
    threshold: FloatProperty(name="Threshold", description="Crest line strength threshold", default=2.0,
                             min=0.0, soft_max=100.0)
    mark_seams: BoolProperty(name="Mark Seams", description="Mark segment borders as UV seams", default=False)

    @classmethod
    def poll(cls, context):
        return _poll_mesh(cls, context)

    def execute(self, context):
        dg = api()
        obj = _active_mesh(context)
        if obj.data.library is not None:
            self.report({'ERROR'}, f"'{obj.name}': mesh data is linked from a library and cannot be changed")
            return {'CANCELLED'}
        mesh = obj.data
        try:
            arrays = bridge.read_object(obj, edges=True)
            n_poly = len(mesh.polygons)
            if self.segments > n_poly:
                raise dg.MeshError(f"cannot make {self.segments} segments from {n_poly} faces")
            with _Progress(context) as progress:
                lines = None
                if self.feature_weight > 0:
                    lines = cached_crest_lines(arrays, self.rings).filter(self.threshold)
                tri_labels = dg.segment(arrays.V, arrays.F, segments=self.segments,
                                        feature_weight=self.feature_weight, crest_lines=lines, progress=progress)
        except dg.MeshError as exc:
            self.report({'ERROR'}, f"Segmentation failed on '{obj.name}': {exc}")
            return {'CANCELLED'}
        except dg.Cancelled:
            self.report({'WARNING'}, "Segmentation cancelled; nothing changed")
            return {'CANCELLED'}
        # A polygon takes the label of its first triangle.
        labels = np.zeros(n_poly, dtype=np.int32)
        labels[arrays.tri_poly[::-1]] = tri_labels[::-1]
        n_seg = int(labels.max()) + 1 if n_poly else 0
        loop_poly = np.repeat(np.arange(n_poly), np.diff(np.append(
            _get(mesh.polygons, "loop_start", np.int32), len(mesh.loops))))
        loop_edge = _get(mesh.loops, "edge_index", np.int32)
        with bridge.object_mode(context):
            mesh = obj.data
            attr = mesh.attributes.get(ATTR_SEGMENT)
            if attr is not None and (attr.data_type != 'INT' or attr.domain != 'FACE'):
                mesh.attributes.remove(attr)
                attr = None
            if attr is None:
                mesh.attributes.new(ATTR_SEGMENT, 'INT', 'FACE')
            mesh.attributes[ATTR_SEGMENT].data.foreach_set("value", labels)
            # Flat colour per face: a face-corner colour attribute.
            rgba = _segment_colors(max(n_seg, 1))[labels[loop_poly]]
            cattr = mesh.attributes.get(ATTR_SEGMENT_COLOR)
            if cattr is not None and (cattr.data_type != 'FLOAT_COLOR' or cattr.domain != 'CORNER'):
                mesh.attributes.remove(cattr)
                cattr = None
            if cattr is None:
                mesh.color_attributes.new(ATTR_SEGMENT_COLOR, 'FLOAT_COLOR', 'CORNER')
            mesh.attributes[ATTR_SEGMENT_COLOR].data.foreach_set("color", rgba.ravel())
            bridge.set_active_color(mesh, ATTR_SEGMENT_COLOR)
            borders = 0
            if self.mark_seams:
                # An edge is a border when its corners belong to faces of different segments.
                lab = labels[loop_poly]
                lo = np.full(len(mesh.edges), np.iinfo(np.int32).max)
                hi = np.full(len(mesh.edges), -1)
                np.minimum.at(lo, loop_edge, lab)
                np.maximum.at(hi, loop_edge, lab)
                border = (hi >= 0) & (lo != hi)
                borders = int(border.sum())
                _or_edge_flag(mesh, "seam", border)
            mesh.update()
        space = context.space_data
        if getattr(space, "type", None) == 'VIEW_3D' and space.shading.type == 'SOLID':
            space.shading.color_type = 'VERTEX'
        text = (f"Segmented '{obj.name}' into {n_seg} segments (feature weight {self.feature_weight:g}"
                f"{'' if lines is None else f', {len(lines)} crest lines'})")
        if self.mark_seams:
            text += f"; {borders} border edges marked as seams"
        self.report({'INFO'}, text)
        return {'FINISHED'}


def _get(collection, key, dtype):
    buf = np.empty(len(collection), dtype=dtype)
    collection.foreach_get(key, buf)
    return buf


classes = (DGMESH_OT_crest_lines, DGMESH_OT_decimate_features, DGMESH_OT_segment)
