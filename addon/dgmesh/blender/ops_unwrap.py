"""Operators dgmesh.unwrap (low-stretch UV unwrap, thesis chapter 5) and dgmesh.stretch_map.

Charts: the faces to unwrap (the selected faces in Edit mode, all faces in Object mode) are split
into charts along seams and mesh boundaries; a chart's vertices are the face corners joined across
non-seam edges, so a seam that slits a chart without separating it opens a cut. Every chart must be
a topological disk (holes are allowed); a closed or non-disk chart is reported by number and face
count, and nothing is written. UVs are written per face corner of the user's polygons (quads and
n-gons keep their faces; Blender's loop triangulation only feeds the solver), only for the faces
unwrapped; other corners of the active UV map are left untouched.

One native call per object unwraps all its charts (dgmesh.unwrap_charts: the charts' corner classes
as vertices, the chart of each triangle as labels), each exactly as dgmesh.unwrap would alone. Each
chart is scaled to its 3D area, then Blender's packer (uv.pack_islands) lays the charts out; in
Object mode the operator enters Edit mode for the packing with exactly the unwrapped faces selected
and restores the selection afterwards. In Edit mode it never leaves Edit mode (each round trip
costs seconds on a big mesh): it reads the mesh synced from the edit-mesh, reads and writes the
unwrapped corners' UVs through bmesh (a UV map of a mesh in Edit mode has no data) and packs with
only those corners' UVs selected. The report gives the L2 stretch (eq. 5.5) of the active UV map on
the unwrapped faces before and after. Long runs show progress and Esc cancels
(jobs.NativeJobOperator); nothing is written before the computation has finished.
"""

import bmesh
import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from .. import colors
from ..polymesh import ranges, split_charts
from ..unwrapping import UnwrapOptions, UvBoundary, UvWeights
from . import bridge, compat
from .common import enum_id, enum_items, poll_mesh_targets, read_only_reason, report_shown_shape, target_objects
from .jobs import NativeJobOperator, item_shares
from .prefs import api

ATTR_STRETCH = "dg_uv_stretch"
ATTR_STRETCH_COLOR = "dg_uv_stretch_color"

BOUNDARY_ITEMS = enum_items(UvBoundary, {
    "square": ("Square", "Boundary on the unit square (the thesis)"),
    "circle": ("Circle", "Boundary on a circle"),
    "free": ("Free", "Natural boundary of a conformal map (falls back to a circle if it would fold)"),
})
WEIGHTS_ITEMS = enum_items(UvWeights, {
    "floater": ("Floater", "Floater's shape-preserving weights (the thesis)"),
    "mean_value": ("Mean Value", "Mean-value weights"),
    "cotangent": ("Cotangent", "Harmonic weights (may fold the initial map)"),
    "uniform": ("Uniform", "Tutte's uniform weights"),
    "auto": ("Auto", "Cotangent, or Floater's where the cotangent map folds (lowest stretch measured)"),
})
# Property defaults: the library's own (dgmesh/unwrap.h), measured on the CGAL disk scans (bench
# unwrap_quality): free boundary, Auto weights, eta 0.5 and a sliding boundary give the lowest L2
# stretch on every model; the thesis's setting is Square, Floater, eta 1, no sliding.
DEFAULTS = UnwrapOptions()


def _read_polys(mesh):
    """Polygon and loop arrays of a mesh datablock."""
    npoly, nloop, nedge = len(mesh.polygons), len(mesh.loops), len(mesh.edges)
    start = np.empty(npoly, np.int32)
    total = np.empty(npoly, np.int32)
    sel = np.empty(npoly, bool)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    mesh.polygons.foreach_get("select", sel)
    lv = np.empty(nloop, np.int32)
    le = np.empty(nloop, np.int32)
    mesh.loops.foreach_get("vertex_index", lv)
    mesh.loops.foreach_get("edge_index", le)
    seam = np.empty(nedge, bool)
    mesh.edges.foreach_get("use_seam", seam)
    return start, total, sel, lv, le, seam


class DGMESH_OT_unwrap(NativeJobOperator, bpy.types.Operator):
    bl_idname = "dgmesh.unwrap"
    bl_label = "Low-Stretch Unwrap"
    bl_description = (
        "Unwrap the selected faces (all faces in Object mode) into charts cut along seams, with "
        "low stretch by stretch equalization, and pack the charts. Charts holding a pinned UV are left "
        "as they are"
    )
    bl_options = {'REGISTER', 'UNDO'}

    boundary: EnumProperty(name="Boundary", items=BOUNDARY_ITEMS, default=enum_id(DEFAULTS.boundary))
    weights: EnumProperty(name="Weights", items=WEIGHTS_ITEMS, default=enum_id(DEFAULTS.weights))
    eta: FloatProperty(name="Strength", description="Exponent eta of each equalization step (eq. 5.6)",
                       default=DEFAULTS.eta, min=0.05, max=1.0)
    slide_boundary: BoolProperty(
        name="Slide Boundary", default=DEFAULTS.slide_boundary,
        description="Also equalize stretch along the boundary polygon (its shape stays, so no flips)")
    # UnwrapOptions.iterations is -1 for Uopt, else the number of steps: here a switch and a count.
    optimal: BoolProperty(name="Optimal", default=DEFAULTS.iterations < 0,
                          description="Iterate until the L2 stretch stops decreasing")
    steps: IntProperty(name="Steps", default=1, min=0, max=200,
                       description="Equalization steps when not optimal (0: initial map, 1: one step)")
    stretch_iterations: IntProperty(
        name="Minimize Stretch", default=DEFAULTS.stretch_iterations, min=0, max=500,
        description="Newton steps of a final direct minimisation of the L2 stretch with a barrier against "
                    "flips (0: off; kept only when it lowers the stretch)")
    pack: BoolProperty(name="Pack", default=True,
                       description="Pack the charts with Blender's packer (charts keep their 3D size ratio)")
    margin: FloatProperty(name="Margin", default=0.02, min=0.0, max=0.5)

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        for name in ("boundary", "weights", "eta", "slide_boundary", "optimal"):
            layout.prop(self, name)
        row = layout.row()
        row.active = not self.optimal  # steps count only when not iterating to the optimum
        row.prop(self, "steps")
        layout.prop(self, "stretch_iterations")
        layout.prop(self, "pack")
        row = layout.row()
        row.active = self.pack
        row.prop(self, "margin")

    # --- main thread: read --------------------------------------------------------------------
    def prepare(self, context):
        dg = api()
        edit = context.mode == 'EDIT_MESH'
        items = []
        targets = target_objects(context)
        # Edit mode: hold the edit-meshes' bmesh wrappers until finish, so that from_edit_mesh gives
        # the same ones: the first loop wrapped adds a layer to every loop (0.3 s at 1M triangles),
        # and freeing the wrapper removes it.
        self._bms = [bmesh.from_edit_mesh(o.data) for o in context.objects_in_mode_unique_data
                     if o.type == 'MESH'] if edit else []
        for obj in targets:
            reason = read_only_reason(obj)
            if reason:
                self.report({'ERROR'}, f"Unwrap failed on '{obj.name}': {reason}")
                return None
            try:
                item = read_charts(obj, edit, dg)
            except dg.MeshError as exc:
                self.report({'ERROR'}, f"Unwrap failed on '{obj.name}': {exc}")
                return None
            if item is not None:
                items.append(item)
        self._n_pinned = sum(it["n_pinned"] for it in items)
        items = [it for it in items if it["charts"]]
        if not items:
            faceless = [o.name for o in targets if not len(o.data.polygons)]
            if self._n_pinned:
                msg = self._pinned_note()
            elif faceless and len(faceless) == len(targets):
                msg = f"No faces to unwrap: {', '.join(map(repr, faceless[:3]))} " + (
                    "has no faces" if len(faceless) == 1 else "have no faces")
            else:
                msg = "No faces to unwrap (select faces in Edit mode)" if edit else "No faces to unwrap"
            self.report({'WARNING'}, msg)
            return None
        opts = dict(boundary=self.boundary.lower(), weights=self.weights.lower(), eta=self.eta,
                    slide_boundary=self.slide_boundary,
                    iterations="optimal" if self.optimal else self.steps,
                    stretch_iterations=self.stretch_iterations)

        def work(progress):
            # One native call per object for all its charts; all or nothing: the first chart that
            # cannot be unwrapped stops the run.
            for it, sub in item_shares(progress, items, lambda it: len(it["class_F"])):
                try:
                    r = dg.unwrap_charts(it["class_V"], it["class_F"], it["tri_chart"], progress=sub, **opts)
                except dg.UnwrapChartError as exc:
                    _, Fc, _, first_poly = it["charts"][exc.chart]
                    raise dg.MeshError(
                        f"'{it['name']}' chart {exc.chart + 1} of {len(it['charts'])} ({len(Fc)} triangles, with "
                        f"face #{first_poly}): {exc.reason}. Add seams so that every chart is a disk, or split "
                        "it with DG Mesh > Segment") from None
                it["uv_class"] = np.zeros((it["n_classes"], 2))
                it["stretch"] = []
                for (classes, Fc, Vc, _), rc in zip(it["charts"], r.charts):
                    # Scale each chart to its 3D area so the packer keeps the charts' relative size.
                    uv = rc.uv - rc.uv.mean(0)
                    a3 = _area3(Vc, Fc)
                    auv = _area2(uv, Fc)
                    it["uv_class"][classes] = uv * (np.sqrt(a3 / auv) if auv > 0 else 1.0)
                    it["stretch"].append((rc.final.stretch_l2, len(Fc), rc.warnings))
            return items

        return work

    # --- main thread: write, pack, report ------------------------------------------------------
    def finish(self, context, items):
        try:
            return self._finish(context, items)
        finally:
            self._bms = None

    def _finish(self, context, items):
        dg = api()
        edit = context.mode == 'EDIT_MESH'
        corners = {}
        for it in items:
            obj = bpy.data.objects.get(it["name"])
            ok = obj is not None and (len(obj.data.loops), len(obj.data.polygons)) == it["counts"]
            if ok and edit:
                # The edit-mesh itself, not its last sync: the unwrapped faces still selected and shown.
                corners[it["name"]] = _edit_corners(obj.data, it)
                ok = corners[it["name"]] is not None
            if not ok:
                self.report({'ERROR'}, f"Unwrap failed on '{it['name']}': the mesh changed while it was computed")
                return {'CANCELLED'}
        for it in items:
            uv = _chart_uvs(it, normalise=not self.pack)
            if edit:
                mesh, bm, lay, loops = corners[it["name"]]
                if lay is None:  # a new layer invalidates the loops' Python objects
                    bm.loops.layers.uv.new("UVMap")
                    corners[it["name"]] = _edit_corners(mesh, it)
                _edit_write_uvs(corners[it["name"]], uv)
            else:
                _write_uvs(bpy.data.objects[it["name"]], it, uv)
        packed = False
        if self.pack:
            packed = self._pack_edit(context, corners) if edit else self._pack_objects(context, items)
        # Measure the stretch of what was written, over the same triangles as "before".
        after = []
        for it in items:
            if edit:
                uv = _edit_read(corners[it["name"]])[0]
            else:
                uv = _loop_uvs(bpy.data.objects[it["name"]].data, it["loops"], pins=False)[0]
            after.append(dg.uv_metrics(it["V"], it["F"], uv[it["tri_corner"]]))
        for mesh, _, _, _ in corners.values():
            bmesh.update_edit_mesh(mesh, loop_triangles=False, destructive=False)
        n_charts = sum(len(it["charts"]) for it in items)
        n_tris = sum(len(it["F"]) for it in items)
        l2 = float(np.sqrt(sum(m.stretch_l2 ** 2 * len(it["F"]) for m, it in zip(after, items)) / n_tris))
        flipped = sum(m.flipped for m in after)
        zero = sum(m.zero_area for m in after)
        before = [it["before"] for it in items]
        text = f"Unwrapped {n_charts} chart(s) on {len(items)} object(s): L2 stretch {l2:.3f}"
        if all(b is not None for b in before):
            b = float(np.sqrt(sum(x ** 2 * len(it["F"]) for x, it in zip(before, items)) / n_tris))
            text += f" (before {b:.3f})" if np.isfinite(b) else " (before: degenerate UVs)"
        else:
            text += " (no UV map before)"
        text += f", {flipped} flipped, {zero} zero-area"
        if self.pack:
            text += ", packed" if packed else ", not packed"
        self.report({'INFO'}, text)
        report_shown_shape(self, [bpy.data.objects[it["name"]] for it in items])
        if self._n_pinned:
            self.report({'WARNING'}, self._pinned_note())
        warnings = sorted({w for it in items for (_, _, ws) in it["stretch"] for w in ws})
        for w in warnings[:3]:
            self.report({'WARNING'}, w)
        return {'FINISHED'}

    def _pinned_note(self):
        return (f"{self._n_pinned} chart(s) with pinned UVs left as they are (Low-Stretch Unwrap does not use "
                "pins; Alt+P unpins)")

    def _pack_edit(self, context, corners):
        """Edit mode: Blender's packer takes the islands of the shown, selected faces of every edited
        object whose UVs are selected (the UV editor's selection, synced selection off). Select
        exactly the unwrapped corners' UVs for it (not the pinned charts left alone, nor other
        edited objects'), then put the UV selection back. Turning synced selection off rewrites the
        UV flags in 5.x (from the mesh selection, or flushed): they are set after it, and every
        edit-mesh's whole UV selection is put back."""
        tool = context.scene.tool_settings
        sync = tool.use_uv_select_sync
        saved = []
        try:
            for obj in context.objects_in_mode_unique_data:
                if obj.type != 'MESH':
                    continue
                bm = bmesh.from_edit_mesh(obj.data)
                lay = bm.loops.layers.uv.active
                if lay is None:
                    continue
                # A Python pass over the faces, but no toggle: 0.02 s at 500K faces.
                loops = [l for f in bm.faces if f.select and not f.hide for l in f.loops]
                # bm keeps the loops valid
                saved.append((bm, lay, loops, compat.bm_uv_flags(loops, lay), compat.bm_uv_select_state(bm, lay)))
            tool.use_uv_select_sync = False
            for _, lay, loops, _, _ in saved:
                compat.bm_set_uv_flags(loops, lay, False)
            for _, _, lay, loops in corners.values():
                compat.bm_set_uv_flags(loops, lay, True)
            compat.pack_islands(self.margin)
            return True
        except RuntimeError as exc:
            self.report({'WARNING'}, f"Packing failed: {exc}")
            return False
        finally:
            tool.use_uv_select_sync = sync
            for bm, lay, loops, flags, state in saved:
                compat.bm_set_uv_flags(loops, lay, flags)
                compat.bm_set_uv_select_state(bm, lay, state)

    def _pack_objects(self, context, items):
        """Object mode: Blender's packer on the unwrapped faces only: Edit mode for the duration with
        exactly those faces selected and none hidden (Object mode unwraps hidden faces too), then
        selection, hiding, the UV selection (the packer selects every UV) and mode back as they were."""
        names = [it["name"] for it in items]
        saved = {}
        uv_sel = {name: compat.uv_selection(bpy.data.objects[name].data) for name in names}
        layer = context.view_layer
        active = layer.objects.active
        sel_objs = [o for o in layer.objects if o.select_get()]
        tool = context.scene.tool_settings
        sync = tool.use_uv_select_sync
        try:
            for it in items:
                mesh = bpy.data.objects[it["name"]].data
                saved[it["name"]] = (_get_flags(mesh, "select"), _get_flags(mesh, "hide"))
                _set_flags(mesh, "hide", [np.zeros(len(c), bool) for c in saved[it["name"]][1]])
                _set_face_selection(mesh, it["mask"])
            for o in layer.objects:
                o.select_set(o.name in names)
            layer.objects.active = bpy.data.objects[names[0]]
            bpy.ops.object.mode_set(mode='EDIT')
            tool.use_uv_select_sync = False
            bpy.ops.uv.select_all(action='SELECT')
            compat.pack_islands(self.margin)
            return True
        except RuntimeError as exc:
            self.report({'WARNING'}, f"Packing failed: {exc}")
            return False
        finally:
            tool.use_uv_select_sync = sync
            if context.mode != 'OBJECT':
                bpy.ops.object.mode_set(mode='OBJECT')
            for name, (sel, hide) in saved.items():
                mesh = bpy.data.objects[name].data
                _set_flags(mesh, "select", sel)
                _set_flags(mesh, "hide", hide)
                compat.set_uv_selection(mesh, uv_sel[name])
            for o in layer.objects:
                o.select_set(o in sel_objs)
            layer.objects.active = active


def _area3(V, F):
    return 0.5 * float(np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum())


def _area2(U, F):
    a, b, c = U[F[:, 0]], U[F[:, 1]], U[F[:, 2]]
    return 0.5 * float(np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])).sum())


def _loop_uvs(mesh, loops, pins=True):
    """Object mode: the active UV map's UVs (k, 2) and pins (k,) (with ``pins``, else None) at the
    corners ``loops``, or (None, None) without a UV map."""
    layer = mesh.uv_layers.active
    if layer is None:
        return None, None
    uv = bridge.get_array(layer.data, "uv", np.float32, 2)[loops].astype(np.float64)
    if not pins:
        return uv, None
    return uv, compat.uv_pins(mesh)[loops]


def _edit_corners(mesh, it):
    """Edit mode: (mesh, its bmesh, the active UV layer or None, the bmesh loops of the polygons
    ``it["polys"]`` in the order of ``it["loops"]``), or None when the edit-mesh no longer matches
    (other face or corner counts, one of those faces not shown and selected). Face i of the
    edit-mesh is polygon i of the mesh synced from it, its loops from the polygon's first corner
    on. The bmesh is returned to keep the loops valid (freeing its Python object invalidates them).
    A Python pass over the unwrapped faces only: bmesh has no bulk access."""
    bm = bmesh.from_edit_mesh(mesh)
    if len(bm.faces) != it["n_faces"]:
        return None
    bm.faces.ensure_lookup_table()
    faces = [bm.faces[p] for p in it["polys"].tolist()]
    if ([len(f.loops) for f in faces] != it["poly_total"].tolist()
            or not all(f.select and not f.hide for f in faces)):
        return None
    loops = [l for f in faces for l in f.loops]
    total = it["poly_total"]
    index = ranges(it["poly_start"], total)
    if np.any(np.diff(index) <= 0):
        loops = [loops[i] for i in np.argsort(index).tolist()]
    return mesh, bm, bm.loops.layers.uv.active, loops


def _edit_read(corners):
    """The UVs (k, 2) and pins (k,) of the corners from :func:`_edit_corners`, (None, None) without
    a UV map."""
    _, _, lay, loops = corners
    if lay is None:
        return None, None
    data = [l[lay] for l in loops]
    uv = np.array([d.uv[:] for d in data], np.float64).reshape(-1, 2)
    return uv, np.array([d.pin_uv for d in data], bool)


def _edit_write_uvs(corners, uv):
    _, _, lay, loops = corners
    for l, p in zip(loops, uv.tolist()):
        l[lay].uv = p


def read_charts(obj, edit, dg):
    """Charts of the faces to unwrap, as arrays for the worker (no bpy objects inside). Charts
    holding a pinned UV are left as they are (``n_pinned`` of them): the unwrap has no pins, and a
    pin means the user placed those UVs. Edit mode: the shown, selected faces, read from the mesh
    synced from the edit-mesh, their UVs from the edit-mesh."""
    mesh = obj.data
    if edit:
        obj.update_from_editmode()
    arrays = bridge.read_mesh(mesh)
    start, total, sel, lv, le, seam = _read_polys(mesh)
    mask = sel & ~bridge.get_array(mesh.polygons, "hide") if edit else np.ones(len(start), bool)
    if not mask.any():
        return None
    corner_class, chart_of_class = split_charts(start, total, mask, le, seam, lv)
    loops = np.nonzero(corner_class >= 0)[0]
    item = dict(name=obj.name, counts=(len(mesh.loops), len(mesh.polygons)), n_faces=len(start))

    def faces(mask):
        polys = np.flatnonzero(mask)
        return dict(mask=mask, polys=polys, poly_start=start[polys], poly_total=total[polys])

    if edit:
        corners = _edit_corners(mesh, {**item, **faces(mask)})
        if corners is None:  # cannot be, right after the sync
            raise dg.MeshError("the edit-mesh does not match the mesh synced from it")
        uv, pin = _edit_read(corners)
    else:
        uv, pin = _loop_uvs(mesh, loops)
    n_pinned = 0
    if pin is not None and pin.any():
        has_pin = np.zeros(len(chart_of_class), bool)
        has_pin[chart_of_class[corner_class[loops[pin]]]] = True
        n_pinned = int(has_pin.sum())
        poly_chart = np.where(mask, chart_of_class[corner_class[start]], -1)  # by a polygon's first corner
        mask &= ~((poly_chart >= 0) & has_pin[np.maximum(poly_chart, 0)])
        if not mask.any():
            return dict(name=obj.name, n_pinned=n_pinned, charts=[])
        corner_class, chart_of_class = split_charts(start, total, mask, le, seam, lv)
        keep = corner_class[loops] >= 0
        loops, uv = loops[keep], uv[keep]
    tri_mask = mask[arrays.tri_poly]
    tri_loops = arrays.tri_loops[tri_mask]
    tri_corner = np.searchsorted(loops, tri_loops)  # rows of `loops` (and of uv)
    tri_cls = corner_class[tri_loops]
    tri_poly = arrays.tri_poly[tri_mask]
    vert_of_class = np.empty(len(chart_of_class), np.int64)
    vert_of_class[corner_class[loops]] = lv[loops]
    F = arrays.F[tri_mask]
    before = None
    if uv is not None:
        try:
            before = dg.uv_metrics(arrays.V, F, uv[tri_corner]).stretch_l2
        except ValueError:
            before = None
    charts = []
    tri_chart = chart_of_class[tri_cls[:, 0]]
    for c in range(chart_of_class.max() + 1):
        in_c = tri_chart == c
        classes, Fc = np.unique(tri_cls[in_c], return_inverse=True)
        Fc = Fc.reshape(-1, 3).astype(np.int32)
        Vc = np.ascontiguousarray(arrays.V[vert_of_class[classes]])
        charts.append((classes, Fc, Vc, int(tri_poly[in_c].min())))
    item.update(faces(mask), n_pinned=n_pinned, loops=loops, corner_class=corner_class[loops],
                n_classes=len(chart_of_class), charts=charts, V=arrays.V, F=F, tri_corner=tri_corner,
                before=before, class_V=np.ascontiguousarray(arrays.V[vert_of_class]), class_F=tri_cls,
                tri_chart=tri_chart)
    return item


def _chart_uvs(it, normalise):
    """The charts' UVs at the unwrapped corners (rows of ``it["loops"]``). Blender stores UVs as
    float32 and the packer transforms them in float32: charts written at their 3D scale
    (coordinates of tens of units) lose slivers to rounding (two zero-area triangles on CGAL's
    mannequin-devil). Every chart goes into [0, 1]^2: on its own without packing (``normalise``),
    with one common scale (the charts' size ratio) for the packer."""
    uvc = it["uv_class"].copy()
    common = 1.0
    if not normalise and len(uvc):
        common = max(max(float((uvc[c].max(0) - uvc[c].min(0)).max()) for c, _, _, _ in it["charts"]), 1e-300)
    for classes, _, _, _ in it["charts"]:
        p = uvc[classes]
        lo, hi = p.min(0), p.max(0)
        s = max(float((hi - lo).max()), 1e-300) if normalise else common
        uvc[classes] = (p - lo) / s + 0.5 * (1 - (hi - lo) / s)
    return uvc[it["corner_class"]]


def _write_uvs(obj, it, uv):
    """Object mode: writes the unwrapped corners' UVs into the active UV map (created if none);
    other corners are left untouched."""
    mesh = obj.data
    if mesh.uv_layers.active is None:
        mesh.uv_layers.new(name="UVMap")
    layer = mesh.uv_layers.active
    full = bridge.get_array(layer.data, "uv", np.float32, 2)
    full[it["loops"]] = uv
    layer.data.foreach_set("uv", full.ravel())
    mesh.update()


def _get_flags(mesh, prop):
    """A boolean flag ("select", "hide") of the vertices, edges and faces."""
    return [bridge.get_array(coll, prop) for coll in (mesh.vertices, mesh.edges, mesh.polygons)]


def _set_flags(mesh, prop, saved):
    for coll, a in zip((mesh.vertices, mesh.edges, mesh.polygons), saved):
        coll.foreach_set(prop, a)
    mesh.update()


def _set_face_selection(mesh, mask):
    """Selects exactly the faces in mask (with their vertices and edges)."""
    start, total = np.empty(len(mesh.polygons), np.int32), np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", start)
    mesh.polygons.foreach_get("loop_total", total)
    lv = np.empty(len(mesh.loops), np.int32)
    le = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", lv)
    mesh.loops.foreach_get("edge_index", le)
    in_mask = np.repeat(mask, total)
    vs = np.zeros(len(mesh.vertices), bool)
    vs[lv[in_mask]] = True
    es = np.zeros(len(mesh.edges), bool)
    es[le[in_mask]] = True
    mesh.vertices.foreach_set("select", vs)
    mesh.edges.foreach_set("select", es)
    mesh.polygons.foreach_set("select", mask)
    mesh.update()


class DGMESH_OT_stretch_map(bpy.types.Operator):
    bl_idname = "dgmesh.stretch_map"
    bl_label = "UV Stretch Map"
    bl_description = "Colour the vertices by the stretch of the active UV map (eq. 5.1)"
    bl_options = {'REGISTER', 'UNDO'}

    checker: BoolProperty(name="Checker Material", default=False,
                          description="Show a checker texture on every face for a visual check: a 'DG "
                          "Checker' material, added to a mesh without materials, else put in the object's "
                          "slots linked to the object (the mesh keeps its materials: set a slot's Link back "
                          "to Data to see them)")
    percentile: FloatProperty(name="Range Percentile", default=95.0, min=50.0, max=100.0)

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def execute(self, context):
        dg = api()
        targets = target_objects(context)
        # Linked duplicates share the mesh (one target) but not object-linked material slots.
        users = context.objects_in_mode if context.mode == 'EDIT_MESH' else context.selected_objects
        done, failures = [], []
        # Outside Edit mode: an edit-mesh's UV map is only in the datablock once Edit mode is left.
        with bridge.object_mode(context):
            # 1. Compute everything before writing anything.
            for obj in targets:
                mesh = obj.data
                reason = read_only_reason(obj)
                if reason:
                    failures.append((obj.name, reason))
                    continue
                if mesh.uv_layers.active is None:
                    failures.append((obj.name, "it has no UV map"))
                    continue
                try:
                    arrays = bridge.read_object(obj)
                    uv = bridge.get_array(mesh.uv_layers.active.data, "uv", np.float32, 2)
                    s = np.asarray(dg.uv_stretch(arrays.V, arrays.F, uv, uv_faces=arrays.tri_loops), dtype=np.float64)
                except dg.MeshError as exc:
                    failures.append((obj.name, str(exc)))
                    continue
                except Exception as exc:  # anything else from the native side: report, don't crash
                    failures.append((obj.name, f"internal error: {type(exc).__name__}: {exc}"))
                    continue
                s = np.where(np.isfinite(s), s, np.nan)
                if not np.isfinite(s).any():
                    failures.append((obj.name, f"every face of UV map '{mesh.uv_layers.active.name}' has zero area "
                                               "(no stretch to measure)"))
                    continue
                done.append((obj, s))
            # 2. Write the valid ones.
            for obj, s in done:
                bridge.write_point_float(obj.data, ATTR_STRETCH, np.nan_to_num(s, nan=0.0))
                rgba = colors.sequential(s, vmin=1.0, percentile=self.percentile)
                bridge.write_point_color(obj.data, ATTR_STRETCH_COLOR, rgba)
                if self.checker:
                    _assign_checker(obj.data, [o for o in users if o.data == obj.data])
        for name, message in failures:
            self.report({'ERROR'}, f"UV stretch map failed on '{name}': {message}")
        if not done:
            return {'CANCELLED'}
        vals = np.concatenate([s for _, s in done])
        vals = vals[np.isfinite(vals)]
        self.report({'INFO'}, f"Stretch map: vertex stretch {vals.min():.3g} .. {vals.max():.3g}")
        report_shown_shape(self, [obj for obj, _ in done])
        return {'FINISHED'}


def _assign_checker(mesh, objects):
    """The checker on every face of ``objects`` (the targeted users of ``mesh``)."""
    mat = bpy.data.materials.get("DG Checker") or bpy.data.materials.new("DG Checker")
    compat.use_shader_nodes(mat)
    nt = mat.node_tree
    if "DG Checker" not in nt.nodes:
        tex = nt.nodes.new("ShaderNodeTexChecker")
        tex.name = "DG Checker"
        tex.inputs["Scale"].default_value = 16.0
        uvn = nt.nodes.new("ShaderNodeUVMap")
        nt.links.new(uvn.outputs["UV"], tex.inputs["Vector"])
        bsdf = nt.nodes.get("Principled BSDF")
        if bsdf is not None:
            nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    if not len(mesh.materials):
        mesh.materials.append(mat)  # every user of the mesh shows it
        return
    # Faces use their slots' materials: override every slot for these objects only, leaving the
    # mesh's materials and material indices as they are.
    for obj in objects:
        for slot in obj.material_slots:
            slot.link = 'OBJECT'
            slot.material = mat


classes = (DGMESH_OT_unwrap, DGMESH_OT_stretch_map)
