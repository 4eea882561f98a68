"""Operator dgmesh.auto_unwrap: one-click unwrap of closed or complex meshes (issue 29).

The faces to unwrap (the selected, shown faces in Edit mode, all faces in Object mode) are cut into
disk charts by dgmesh.auto_unwrap (dgmesh/charts.h: VSA segmentation, tubes cut open from rim to
rim, other charts split until each is a disk, the worst chart split until the whole map is within
the stretch target, neighbours merged while it holds; each unwrapped by the low-stretch method); a
polygon is never cut (its triangles are one group). The UVs go into the active UV map (created if
none) at the unwrapped faces' corners only, seams (edge.use_seam) are set on the cuts (between two
charts or inside one) and cleared on the other edges inside the unwrapped faces (edges on the
selection's border keep theirs), then Blender's packer lays out the charts (as dgmesh.unwrap
packs). Long runs show progress and Esc cancels (jobs.NativeJobOperator); nothing is written
before the computation has finished.
"""

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from ..unwrapping import AutoUnwrapOptions
from . import bridge
from .common import poll_mesh_targets, read_only_reason, report_shown_shape, target_objects
from .jobs import NativeJobOperator, item_shares
from .ops_unwrap import DGMESH_OT_unwrap, _read_polys
from .prefs import api

DEFAULTS = AutoUnwrapOptions()


def read_faces(obj, edit):
    """The faces to unwrap of a mesh object as arrays for the worker, or None when there are none."""
    mesh = obj.data
    if edit:
        obj.update_from_editmode()
    arrays = bridge.read_mesh(mesh)
    start, total, sel, lv, le, seam = _read_polys(mesh)
    mask = sel & ~bridge.get_array(mesh.polygons, "hide") if edit else np.ones(len(start), bool)
    if not mask.any():
        return None
    tri_mask = mask[arrays.tri_poly]
    F = arrays.F[tri_mask]
    used, Fc = np.unique(F, return_inverse=True)
    return dict(name=obj.name, counts=(len(mesh.loops), len(mesh.polygons)), mask=mask, used=used,
                V=np.ascontiguousarray(arrays.V[used]), F=Fc.reshape(-1, 3).astype(np.int32),
                groups=arrays.tri_poly[tri_mask].astype(np.int32), tri_loops=arrays.tri_loops[tri_mask],
                loop_edge=le, poly_total=total, n_edges=len(mesh.edges))


def seam_flags(it, chart, cuts, edge_verts):
    """(edges inside the unwrapped faces, their new use_seam): an edge all of whose corners belong to
    unwrapped faces is a seam when those faces lie in different charts, or when it is one of the
    cuts inside a chart (``cuts``: the result's seams, vertex pairs of it["V"]; ``edge_verts``: the
    mesh's (edges, 2) vertices)."""
    mask, total, le = it["mask"], it["poly_total"], it["loop_edge"]
    poly_chart = np.full(len(mask), -1, np.int64)
    poly_chart[it["groups"]] = chart  # every triangle of a polygon is in the polygon's chart
    loop_chart = np.repeat(poly_chart, total)
    n = it["n_edges"]
    loops_all = np.bincount(le, minlength=n)
    loops_in = np.bincount(le, weights=loop_chart >= 0, minlength=n)
    inside = (loops_all > 0) & (loops_in == loops_all)
    inner = loop_chart >= 0
    lo = np.full(n, np.iinfo(np.int64).max)
    hi = np.full(n, -1)
    np.minimum.at(lo, le[inner], loop_chart[inner])
    np.maximum.at(hi, le[inner], loop_chart[inner])
    n_verts = int(max(edge_verts.max(initial=0), it["used"].max(initial=0))) + 1
    c = np.sort(it["used"][cuts.reshape(-1, 2)], axis=1).astype(np.int64)
    e = np.sort(edge_verts, axis=1).astype(np.int64)
    in_cuts = np.isin(e[:, 0] * n_verts + e[:, 1], c[:, 0] * n_verts + c[:, 1])
    return inside, inside & ((lo != hi) | in_cuts)


class DGMESH_OT_auto_unwrap(NativeJobOperator, bpy.types.Operator):
    bl_idname = "dgmesh.auto_unwrap"
    bl_label = "Auto Unwrap (Disk Charts)"
    bl_description = (
        "Cut the selected faces (all faces in Object mode) of closed or complex meshes into disk charts "
        "along high curvature, unwrap each with low stretch, mark the cuts as seams and pack the charts"
    )
    bl_options = {'REGISTER', 'UNDO'}

    target: EnumProperty(name="Target", items=[
        ('STRETCH', "Stretch", "Split the worst chart until the whole map's L2 stretch is at most Target "
                               "Stretch and no chart's is above Max Stretch, then merge charts within both"),
        ('CHARTS', "Chart Count", "Start from this many charts; split only charts that are not disks"),
    ], default='STRETCH')
    target_stretch: FloatProperty(name="Target Stretch", default=DEFAULTS.target_stretch, min=1.001, max=10.0,
                                  description="Largest L2 stretch of the whole map (1: no stretch)")
    max_stretch: FloatProperty(name="Max Stretch", default=DEFAULTS.max_stretch, min=1.001, max=10.0,
                               description="Largest L2 stretch any one chart may keep (1: no stretch)")
    charts: IntProperty(name="Charts", default=8, min=1, max=100000,
                        description="Charts of the initial segmentation (more when needed for disks)")
    mark_seams: BoolProperty(name="Mark Seams", default=True,
                             description="Set seams on the cuts between charts (and clear them elsewhere "
                                         "inside the unwrapped faces)")
    pack: BoolProperty(name="Pack", default=True, description="Pack the charts with Blender's packer")
    margin: FloatProperty(name="Margin", default=0.02, min=0.0, max=0.5)

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "target")
        if self.target == 'STRETCH':
            layout.prop(self, "target_stretch")
            layout.prop(self, "max_stretch")
        else:
            layout.prop(self, "charts")
        layout.prop(self, "mark_seams")
        layout.prop(self, "pack")
        row = layout.row()
        row.active = self.pack
        row.prop(self, "margin")

    def prepare(self, context):
        dg = api()
        edit = context.mode == 'EDIT_MESH'
        items = []
        for obj in target_objects(context):
            reason = read_only_reason(obj)
            if reason:
                self.report({'ERROR'}, f"Auto unwrap failed on '{obj.name}': {reason}")
                return None
            item = read_faces(obj, edit)
            if item is not None:
                items.append(item)
        if not items:
            self.report({'WARNING'}, "No faces to unwrap (select faces in Edit mode)" if edit else "No faces to unwrap")
            return None
        opts = (dict(target_stretch=self.target_stretch, max_stretch=self.max_stretch) if self.target == 'STRETCH'
                else dict(target_stretch=None, max_stretch=None, merge=False, charts=self.charts))

        def work(progress):
            for it, sub in item_shares(progress, items, lambda it: len(it["F"])):
                try:
                    it["result"] = dg.auto_unwrap(it["V"], it["F"], groups=it["groups"], progress=sub, **opts)
                except dg.MeshError as exc:
                    if isinstance(exc, dg.Cancelled):
                        raise
                    raise dg.MeshError(f"'{it['name']}': {exc}") from None
            return items

        return work

    def finish(self, context, items):
        dg = api()
        for it in items:
            obj = bpy.data.objects.get(it["name"])
            if obj is None or (len(obj.data.loops), len(obj.data.polygons)) != it["counts"]:
                self.report({'ERROR'}, f"Auto unwrap failed on '{it['name']}': the mesh changed while it was computed")
                return {'CANCELLED'}
        packed = False
        with bridge.object_mode(context):
            for it in items:
                mesh = bpy.data.objects[it["name"]].data
                if mesh.uv_layers.active is None:
                    mesh.uv_layers.new(name="UVMap")
                layer = mesh.uv_layers.active
                full = bridge.get_array(layer.data, "uv", np.float32, 2)
                full[it["tri_loops"].ravel()] = np.asarray(it["result"].uv)
                layer.data.foreach_set("uv", full.ravel())
                if self.mark_seams:
                    inside, cut = seam_flags(it, np.asarray(it["result"].chart), np.asarray(it["result"].seams),
                                             bridge.get_array(mesh.edges, "vertices", np.int32, 2))
                    seam = bridge.get_array(mesh.edges, "use_seam")
                    seam[inside] = cut[inside]
                    mesh.edges.foreach_set("use_seam", seam)
                mesh.update()
            if self.pack:
                packed = DGMESH_OT_unwrap._pack_objects(self, context, items)
            after = []
            for it in items:
                mesh = bpy.data.objects[it["name"]].data
                uv = bridge.get_array(mesh.uv_layers.active.data, "uv", np.float32, 2).astype(np.float64)
                after.append(dg.uv_metrics(it["V"], it["F"], uv[it["tri_loops"]]))
        n_tris = sum(len(it["F"]) for it in items)
        l2 = float(np.sqrt(sum(m.stretch_l2 ** 2 * len(it["F"]) for m, it in zip(after, items)) / n_tris))
        res = [it["result"] for it in items]
        seam_share = sum(r.seam_length for r in res) / max(sum(r.edge_length for r in res), 1e-300)
        text = (f"Auto unwrap: {sum(r.n_charts for r in res)} chart(s) on {len(items)} object(s), L2 stretch "
                f"{l2:.3f} (worst chart {max(float(np.max(r.chart_stretch)) for r in res):.3f}), seams "
                f"{100 * seam_share:.1f}% of the edge length, {sum(m.flipped for m in after)} flipped")
        if self.pack:
            text += ", packed" if packed else ", not packed"
        self.report({'INFO'}, text)
        report_shown_shape(self, [bpy.data.objects[it["name"]] for it in items])
        for w in sorted({w for r in res for w in r.warnings})[:3]:
            self.report({'WARNING'}, w)
        return {'FINISHED'}


classes = (DGMESH_OT_auto_unwrap,)
