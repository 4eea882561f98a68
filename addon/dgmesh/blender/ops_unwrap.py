"""Operators dgmesh.unwrap (low-stretch UV unwrap, thesis chapter 5) and dgmesh.stretch_map.

Charts: the faces to unwrap (the selected faces in Edit mode, all faces in Object mode) are split
into charts along seams and mesh boundaries; a chart's vertices are the face corners joined across
non-seam edges, so a seam that slits a chart without separating it opens a cut. Every chart must be
a topological disk (holes are allowed); a closed or non-disk chart is reported by number and face
count, and nothing is written. UVs are written per face corner of the user's polygons (quads and
n-gons keep their faces; Blender's loop triangulation only feeds the solver), only for the faces
unwrapped; other corners of the active UV map are left untouched.
"""

import sys

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from .. import colors
from . import bridge
from .prefs import api

ATTR_STRETCH = "dg_uv_stretch"
ATTR_STRETCH_COLOR = "dg_uv_stretch_color"


def _poll_fail(cls, message):
    if hasattr(cls, "poll_message_set"):
        cls.poll_message_set(message)
    return False


def _mesh_objects(context):
    if context.mode == 'EDIT_MESH':
        objs = list(context.objects_in_mode_unique_data)
    elif context.mode == 'OBJECT':
        objs = [o for o in context.selected_objects if o.type == 'MESH']
    else:
        return []
    seen, out = set(), []
    for o in objs:
        if o.data.as_pointer() not in seen:
            seen.add(o.data.as_pointer())
            out.append(o)
    return out


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


def split_charts(start, total, face_mask, loop_edge, seam):
    """Charts of the masked polygons: returns (corner_class, chart_of_class) where corner_class[l]
    is the chart vertex of loop l (-1 for loops of unmasked polygons)."""
    uw = sys.modules[api().__name__ + ".unwrap"]  # the module (the package's `unwrap` is the function)
    nloop = len(loop_edge)
    poly_of_loop = np.repeat(np.arange(len(start)), total)
    nxt = np.arange(nloop) + 1
    last = start + total - 1
    nxt[last] = start
    in_mask = face_mask[poly_of_loop]
    loops = np.nonzero(in_mask)[0]
    # Loops of masked polygons sharing a non-seam edge: pair them up (two loops per manifold edge).
    e = loop_edge[loops]
    order = np.argsort(e, kind="stable")
    ls, es = loops[order], e[order]
    same = es[1:] == es[:-1]
    # An edge with exactly two masked loops (three or more: non-manifold, left unjoined).
    first = np.nonzero(same)[0]
    ok = np.ones(len(first), bool)
    if len(first):
        before = np.r_[False, same][first]
        after = np.r_[same, False][first + 1]
        ok = ~before & ~after & ~seam[es[first]]
    a, b = ls[first[ok]], ls[first[ok] + 1]
    # Edge u->v in a's polygon and v->u in b's: a~next(b), next(a)~b.
    vertex_pairs = np.concatenate([np.c_[a, nxt[b]], np.c_[nxt[a], b]]).astype(np.int32)
    cls = uw.chart_labels(nloop, vertex_pairs)
    inner = np.c_[loops, nxt[loops]].astype(np.int32)
    chart_of_loop = uw.chart_labels(nloop, np.concatenate([vertex_pairs, inner]))
    corner_class = np.full(nloop, -1, np.int64)
    used_classes, remap = np.unique(cls[loops], return_inverse=True)
    corner_class[loops] = remap
    chart_of_class = np.empty(len(used_classes), np.int64)
    chart_of_class[remap] = chart_of_loop[loops]
    _, chart_of_class = np.unique(chart_of_class, return_inverse=True)
    return corner_class, chart_of_class


class DGMESH_OT_unwrap(bpy.types.Operator):
    bl_idname = "dgmesh.unwrap"
    bl_label = "Low-Stretch Unwrap"
    bl_description = (
        "Unwrap the selected faces (all faces in Object mode) into charts cut along seams, with "
        "low stretch by stretch equalization, and pack the charts"
    )
    bl_options = {'REGISTER', 'UNDO'}

    boundary: EnumProperty(
        name="Boundary",
        items=(
            ('FREE', "Free", "Natural boundary of a conformal map (falls back to a circle if it would fold)"),
            ('CIRCLE', "Circle", "Boundary on a circle"),
            ('SQUARE', "Square", "Boundary on the unit square (the thesis)"),
        ),
        default='FREE',
    )
    weights: EnumProperty(
        name="Weights",
        items=(
            ('FLOATER', "Floater", "Floater's shape-preserving weights"),
            ('MEAN_VALUE', "Mean Value", "Mean-value weights"),
            ('COTANGENT', "Cotangent", "Harmonic weights (may fold the initial map)"),
            ('UNIFORM', "Uniform", "Tutte's uniform weights"),
        ),
        default='FLOATER',
    )
    eta: FloatProperty(name="Strength", description="Exponent eta of each equalization step",
                       default=1.0, min=0.05, max=1.0)
    optimal: BoolProperty(name="Optimal", default=True,
                          description="Iterate until the L2 stretch stops decreasing")
    iterations: IntProperty(name="Iterations", default=1, min=0, max=200,
                            description="Equalization steps when not optimal (0: initial map)")
    pack: BoolProperty(name="Pack", default=True, description="Pack the charts with Blender's packer")
    margin: FloatProperty(name="Margin", default=0.02, min=0.0, max=0.5)

    @classmethod
    def poll(cls, context):
        if context.mode not in {'OBJECT', 'EDIT_MESH'}:
            return _poll_fail(cls, "Only available in Object mode and mesh Edit mode")
        if not _mesh_objects(context):
            return _poll_fail(cls, "Select one or more mesh objects")
        return True

    def execute(self, context):
        dg = api()
        edit = context.mode == 'EDIT_MESH'
        results, errors = [], []
        objects = _mesh_objects(context)
        # Edit mode keeps UVs in the edit-mesh: work on the synced datablocks, write only if every
        # chart of every object succeeded (all or nothing).
        with bridge.object_mode(context):
            for obj in objects:
                try:
                    results.append(self._compute(obj, edit, dg))
                except ValueError as exc:  # MeshError is a ValueError
                    errors.append(f"'{obj.name}': {exc}")
            results = [r for r in results if r is not None]
            if not errors:
                for r in results:
                    self._write(r)
        if errors:
            for msg in errors:
                self.report({'ERROR'}, f"Unwrap failed on {msg}")
            return {'CANCELLED'}  # nothing written
        if not results:
            self.report({'WARNING'}, "No faces to unwrap (select faces in Edit mode)")
            return {'CANCELLED'}
        if self.pack:
            self._pack(context, results)
        n_charts = sum(len(r["charts"]) for r in results)
        before = [r["before"] for r in results if r["before"] is not None]
        after = np.mean([r["after"] for r in results])
        text = f"Unwrapped {n_charts} chart(s): L2 stretch {after:.3f}"
        if before:
            text += f" (before {np.mean(before):.3f})"
        self.report({'INFO'}, text)
        return {'FINISHED'}

    def _compute(self, obj, edit, dg):
        mesh = obj.data
        arrays = bridge.read_mesh(mesh)
        start, total, sel, lv, le, seam = _read_polys(mesh)
        mask = sel if edit else np.ones(len(start), bool)
        if not mask.any():
            return None
        corner_class, chart_of_class = split_charts(start, total, mask, le, seam)
        tri_mask = mask[arrays.tri_poly]
        tri_loops = arrays.tri_loops[tri_mask]
        tri_cls = corner_class[tri_loops]
        vert_of_class = np.empty(len(chart_of_class), np.int64)
        vert_of_class[corner_class[corner_class >= 0]] = lv[corner_class >= 0]
        # Existing UVs of these corners, for the "before" figure.
        before = None
        uv_layer = mesh.uv_layers.active
        if uv_layer is not None:
            uv = np.empty(2 * len(mesh.loops), np.float32)
            uv_layer.data.foreach_get("uv", uv)
            uv = uv.reshape(-1, 2).astype(np.float64)
            try:
                before = dg.uv_metrics(arrays.V, arrays.F[tri_mask], uv[tri_loops])["stretch_l2"]
            except ValueError:
                before = None
        uv_class = np.zeros((len(chart_of_class), 2))
        charts, stretch = [], []
        tri_chart = chart_of_class[tri_cls[:, 0]]
        for c in range(chart_of_class.max() + 1):
            tc = tri_cls[tri_chart == c]
            classes, Fc = np.unique(tc, return_inverse=True)
            Fc = Fc.reshape(-1, 3).astype(np.int32)
            Vc = arrays.V[vert_of_class[classes]]
            try:
                r = dg.unwrap(Vc, Fc, boundary=self.boundary.lower(), weights=self.weights.lower(),
                              eta=self.eta, iterations="optimal" if self.optimal else self.iterations)
            except ValueError as exc:
                raise ValueError(
                    f"chart {c + 1} of {chart_of_class.max() + 1} ({len(Fc)} triangles): {exc}. "
                    "Add seams so that every chart is a disk, or split it with dgmesh.segment") from None
            uv_class[classes] = r.uv
            charts.append((classes, Fc, Vc))
            stretch.append((r.final["stretch_l2"], len(Fc)))
        after = sum(s * n for s, n in stretch) / sum(n for _, n in stretch)
        loops = np.nonzero(corner_class >= 0)[0]
        return dict(obj=obj, loops=loops, uv=uv_class[corner_class[loops]], charts=charts,
                    before=before, after=after)

    @staticmethod
    def _write(r):
        mesh = r["obj"].data
        if mesh.uv_layers.active is None:
            mesh.uv_layers.new(name="UVMap")
        layer = mesh.uv_layers.active
        uv = np.empty(2 * len(mesh.loops), np.float32)
        layer.data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2)
        # Lay the charts side by side (unit squares) so the packer sees separate islands.
        uv[r["loops"]] = r["uv"]
        layer.data.foreach_set("uv", uv.ravel())
        mesh.update()

    def _pack(self, context, results):
        try:
            if context.mode != 'EDIT_MESH':
                return  # Object mode: charts stay in [0,1]^2 each (packing needs Edit mode)
            bpy.ops.uv.select_all(action='SELECT')
            bpy.ops.uv.pack_islands(margin=self.margin)
        except RuntimeError as exc:
            self.report({'WARNING'}, f"Packing failed: {exc}")


class DGMESH_OT_stretch_map(bpy.types.Operator):
    bl_idname = "dgmesh.stretch_map"
    bl_label = "UV Stretch Map"
    bl_description = "Colour the vertices by the stretch of the active UV map (eq. 5.1)"
    bl_options = {'REGISTER', 'UNDO'}

    checker: BoolProperty(name="Checker Material", default=False,
                          description="Assign a checker-texture material for a visual check")
    percentile: FloatProperty(name="Range Percentile", default=95.0, min=50.0, max=100.0)

    @classmethod
    def poll(cls, context):
        if context.mode not in {'OBJECT', 'EDIT_MESH'}:
            return _poll_fail(cls, "Only available in Object mode and mesh Edit mode")
        if not _mesh_objects(context):
            return _poll_fail(cls, "Select one or more mesh objects")
        return True

    def execute(self, context):
        dg = api()
        done = []
        for obj in _mesh_objects(context):
            mesh = obj.data
            if mesh.uv_layers.active is None:
                self.report({'ERROR'}, f"'{obj.name}' has no UV map")
                continue
            arrays = bridge.read_object(obj)
            uv = np.empty(2 * len(mesh.loops), np.float32)
            mesh.uv_layers.active.data.foreach_get("uv", uv)
            uv = uv.reshape(-1, 2).astype(np.float64)
            s = dg.uv_stretch(arrays.V, arrays.F, uv[arrays.tri_loops])
            done.append((obj, np.where(np.isfinite(s), s, np.nan)))
        if not done:
            return {'CANCELLED'}
        with bridge.object_mode(context):
            for obj, s in done:
                bridge.write_point_float(obj.data, ATTR_STRETCH, np.nan_to_num(s, nan=0.0))
                rgba = colors.sequential(s, vmin=1.0, percentile=self.percentile)
                bridge.write_point_color(obj.data, ATTR_STRETCH_COLOR, rgba)
                if self.checker:
                    _assign_checker(obj)
        vals = np.concatenate([s for _, s in done])
        vals = vals[np.isfinite(vals)]
        self.report({'INFO'}, f"Stretch map: vertex stretch {vals.min():.3g} .. {vals.max():.3g}")
        return {'FINISHED'}


def _assign_checker(obj):
    mat = bpy.data.materials.get("DG Checker") or bpy.data.materials.new("DG Checker")
    mat.use_nodes = True
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
    if mat.name not in obj.data.materials:
        obj.data.materials.append(mat)


classes = (DGMESH_OT_unwrap, DGMESH_OT_stretch_map)
