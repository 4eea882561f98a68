"""Operator dgmesh.remesh: remeshing by double parameterization (thesis 5.4).

Object mode: every selected mesh object must be one disk (one piece, one boundary loop, no
handles); all its faces are replaced by the new triangulation. Edit mode: the selected faces of
each edited object must form one disk chart; they are replaced by the new triangulation, stitched to
the rest of the mesh along the chart's boundary, whose vertices (and edges) are kept as they are, so
the result is as watertight as the input. Non-disk input is an error and nothing is written (all or
nothing over the objects). The new faces take the material and smooth flag of the input polygon
under most of their corners and, in Edit mode, are left selected. The new corners take the UV maps,
corner colours and float, vector and integer corner attributes, the new vertices the vertex-group
weights and point attributes, of the input point each lies on (blended over its input triangle;
integers from its nearest corner); a triangle across a UV seam inside the region takes its corners from
one side's map (the seam then runs along new edges, zig-zagging at the new spacing). Long
runs show progress and Esc cancels (jobs.NativeJobOperator); the mesh is written only when the
computation has finished.
"""

import bmesh
import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from .. import polymesh
from ..polymesh import flip_off_mirror_planes
from ..remeshing import RemeshBoundary, RemeshMode, RemeshOptions
from . import bridge
from .common import enum_id, enum_items, plural, poll_mesh_targets, read_only_reason, report_shown_shape, target_objects
from .jobs import NativeJobOperator, item_shares
from .prefs import api

MODES = enum_items(RemeshMode, {
    "double": ("Double (U0 + Uopt)",
               "Sample on the low-stretch map, triangulate on the near-conformal one (thesis 5.4)"),
    "single_u0": ("Single (U0)", "Sample and triangulate on the near-conformal map (Alliez et al.)"),
    "single_uopt": ("Single (Uopt)", "Sample and triangulate on the low-stretch map"),
})
DEFAULTS = RemeshOptions()  # property defaults: the library's own (dgmesh/remesh.h)


class DGMESH_OT_remesh(NativeJobOperator, bpy.types.Operator):
    bl_idname = "dgmesh.remesh"
    bl_label = "Remesh (Double Parameterization)"
    bl_description = (
        "Replace a disk-shaped mesh (Object mode) or the selected disk-shaped region (Edit mode) by a "
        "new, near-uniform or curvature-adapted triangulation with about the requested vertex count; "
        "the region's boundary vertices are kept so it stays stitched to the rest (in Object mode "
        "unless Resample Boundary)"
    )
    bl_options = {'REGISTER', 'UNDO'}

    # soft_max: the slider's range (a redo-panel drag runs inline, without Esc); typed values go on.
    target_vertices: IntProperty(name="Vertices", default=DEFAULTS.target_vertices, min=8, max=5_000_000,
                                 soft_max=500_000, description="Vertices of the new triangulation, boundary included")
    adaptivity: FloatProperty(name="Adaptivity", default=DEFAULTS.adaptivity, min=0.0, max=1.0,
                              description="0: uniform density; 1: density proportional to curvature")
    resolution: IntProperty(name="Resolution", default=DEFAULTS.resolution, min=16, max=4096, soft_max=2048,
                            description="Control map size in pixels (at most one vertex per pixel)")
    mode: EnumProperty(name="Mode", items=MODES, default=enum_id(DEFAULTS.mode))
    relax: IntProperty(
        name="Relaxation Steps", default=DEFAULTS.lloyd_iterations, min=0, max=100,
        description="At most this many density-weighted Lloyd steps after the error diffusion (evens out the "
                    "vertex spacing; they stop once the vertices settle; 0 = the thesis's plain error diffusion)")
    flips: BoolProperty(
        name="3D Delaunay Flips", default=DEFAULTS.flip_3d,
        description="After the Delaunay triangulation in the parameter plane, flip edges towards a Delaunay "
                    "triangulation of the surface (better angles; beyond the thesis)")
    smooth: IntProperty(
        name="Smoothing", default=DEFAULTS.smooth_iterations, min=0, max=100,
        description="Sweeps of tangential smoothing of the new vertices on the surface (never creating an "
                    "angle below 35 degrees, sharp features kept), each followed by the flips; beyond the thesis")
    resample_boundary: BoolProperty(
        name="Resample Boundary", default=DEFAULTS.boundary == RemeshBoundary.resample,
        description="Object mode only: place new boundary vertices at the target spacing "
                    "(Edit mode always keeps the region's boundary so it stays stitched)")

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        for name in ("target_vertices", "adaptivity", "resolution", "mode", "relax", "flips", "smooth"):
            layout.prop(self, name)
        row = layout.row()
        row.enabled = context.mode != 'EDIT_MESH'
        row.prop(self, "resample_boundary")

    # --- main thread: read --------------------------------------------------------------------
    def prepare(self, context):
        edit = context.mode == 'EDIT_MESH'
        items = []
        for obj in target_objects(context):
            if edit and not bridge.has_selection(obj, "polygons"):
                continue
            reason = read_only_reason(obj)
            if reason:
                self.report({'ERROR'}, f"Remesh failed on '{obj.name}': {reason}")
                return None
            if obj.data.shape_keys is not None:
                self.report({'ERROR'}, f"Remesh failed on '{obj.name}': the mesh has shape keys, which a new "
                            "triangulation cannot carry (remove or apply them first)")
                return None
            arrays = bridge.read_object(obj, sync=not edit)  # has_selection synced the edit-mesh
            mesh = obj.data
            npoly = len(mesh.polygons)
            mask = np.ones(npoly, bool)
            if edit:
                mesh.polygons.foreach_get("select", mask)
            if not mask.any():
                continue
            tri_mask = mask[arrays.tri_poly]
            Fsel = arrays.F[tri_mask]
            ids, Fc = np.unique(Fsel, return_inverse=True)
            # Inner vertices of the region must not be shared with faces outside it, nor carry
            # edges of no face (wire edges): the new triangulation would drop them.
            start = np.empty(npoly, np.int32)
            total = np.empty(npoly, np.int32)
            mesh.polygons.foreach_get("loop_start", start)
            mesh.polygons.foreach_get("loop_total", total)
            lv = bridge.get_array(mesh.loops, "vertex_index", np.int32)
            outside = np.zeros(len(mesh.vertices), bool)
            outside[lv[~np.repeat(mask, total)]] = True
            wire = np.ones(len(mesh.edges), bool)
            wire[bridge.get_array(mesh.loops, "edge_index", np.int32)] = False
            if wire.any():
                outside[bridge.get_array(mesh.edges, "vertices", np.int32, 2)[wire].ravel()] = True
            items.append(dict(name=obj.name, counts=(len(mesh.vertices), len(mesh.loops), npoly),
                              polys=np.nonzero(mask)[0], ids=ids, outside=outside,
                              tri_loops=arrays.tri_loops[tri_mask], tri_poly=arrays.tri_poly[tri_mask],
                              V=np.ascontiguousarray(arrays.V[ids]), F=Fc.reshape(-1, 3).astype(np.int32),
                              mirror=bridge.mirror_axes(obj, arrays.V)[0]))
        if not items:
            self.report({'WARNING'}, "No faces to remesh (select faces in Edit mode)" if edit
                        else "No faces to remesh: the selected meshes have no faces")
            return None
        keep = edit or not self.resample_boundary
        opts = dict(target_vertices=self.target_vertices, adaptivity=self.adaptivity,
                    resolution=self.resolution, mode=self.mode.lower(),
                    boundary="keep" if keep else "resample", flip_3d=self.flips,
                    lloyd_iterations=self.relax, smooth_iterations=self.smooth)
        dg = api()

        def work(progress):
            for it, sub in item_shares(progress, items, lambda it: len(it["F"])):
                try:
                    it["result"] = dg.remesh_full(it["V"], it["F"], progress=sub, **opts)
                except dg.MeshError as exc:
                    what = "the selected faces" if edit else "the mesh"
                    raise dg.MeshError(f"'{it['name']}' ({what}, {len(it['F'])} triangles): {exc}") from None
                if it["mirror"]:
                    r = it["result"]
                    it["result"] = r.replace(F=flip_off_mirror_planes(r.V, r.F, it["mirror"]))
            return items

        return work

    # --- main thread: write and report ----------------------------------------------------------
    def finish(self, context, items):
        # Check everything before writing anything.
        for it in items:
            obj = bpy.data.objects.get(it["name"])
            mesh = obj.data if obj is not None else None
            if mesh is None or (len(mesh.vertices), len(mesh.loops), len(mesh.polygons)) != it["counts"]:
                self.report({'ERROR'}, f"Remesh failed on '{it['name']}': the mesh changed while it was computed")
                return {'CANCELLED'}
            r = it["result"]
            inner = np.ones(len(it["ids"]), bool)
            if len(r.boundary_source):
                inner[r.boundary_source] = False
            if it["outside"][it["ids"][inner]].any():
                self.report({'ERROR'}, f"Remesh failed on '{it['name']}': inner vertices of the selection are "
                                       "shared with unselected faces or loose edges; nothing was changed")
                return {'CANCELLED'}
            it["inner"] = inner
        edit = context.mode == 'EDIT_MESH'
        lines = []
        with bridge.object_mode(context):
            for it in items:
                mesh = bpy.data.objects[it["name"]].data
                refs = bridge.has_vertex_references(mesh)
                new_index, out_index = _replace_region(mesh, it, select_new=edit, renumbering=refs)
                if refs:
                    nearest = polymesh.nearest_output(it["result"].V, it["ids"], it["V"], out_index)
                    bridge.remap_vertex_references(mesh, new_index, nearest)
                r = it["result"]
                lines.append(f"'{it['name']}': {len(it['ids'])} -> {len(r.V)} vertices, "
                             f"{len(it['F'])} -> {len(r.F)} triangles, "
                             f"min angle {polymesh.min_angle_deg(r.V, r.F):.1f} deg")
        for w in sorted({w for it in items for w in it["result"].warnings})[:3]:
            self.report({'WARNING'}, w)
        # A kept boundary far coarser than the new spacing (Add > Plane: 4 corners for thousands of
        # vertices) leaves slivers along it.
        coarse = [it["name"] for it in items if len(it["result"].boundary_source)
                  and len(it["result"].boundary_source) ** 2 < 0.5 * len(it["result"].V)]
        if coarse and not edit:
            self.report({'WARNING'}, f"{', '.join(map(repr, coarse[:3]))}: the kept boundary is much coarser than "
                        "the new vertices (slivers along it): turn on Resample Boundary")
        self.report({'INFO'}, f"Remeshed {plural(len(items), 'region')} ({self.mode.lower()}, target "
                              f"{self.target_vertices}): " + "; ".join(lines))
        report_shown_shape(self, [bpy.data.objects[it["name"]] for it in items])
        return {'FINISHED'}


def _replace_region(mesh, it, select_new, renumbering=False):
    """Deletes the region's faces and inner vertices and adds the new triangulation, reusing the
    region's boundary vertices (kept) so the stitch is exact. Works on a BMesh copy written back
    only at the end; the new faces' corner data and flags are written in bulk after that. Returns
    (with ``renumbering``, else None: the new index of each old vertex, -1 for removed ones, a
    Python loop over the whole mesh; the mesh vertex of each output vertex)."""
    r = it["result"]
    ids = it["ids"]
    # Corner data (UV maps, corner colours) and point data (vertex groups, point attributes)
    # of the new vertices, blended from the input face each lies on (source_face/bary).
    corner = _corner_values(mesh, it, r)
    nb = len(r.boundary_source)
    points = polymesh.blend_attributes(bridge.read_attributes(mesh, 'POINT'),
                                     np.asarray(ids)[it["F"][r.source_face[nb:]]], r.source_bary[nb:])
    source = _source_polygons(mesh, it, r)
    face_values = [(name, a[source]) for name, a in bridge.read_attributes(mesh, 'FACE')]
    material, smooth = (bridge.get_array(mesh.polygons, key, t)[source]
                        for key, t in (("material_index", np.int32), ("use_smooth", bool)))
    bm = bmesh.new()
    try:
        bm.from_mesh(mesh)
        bm.verts.ensure_lookup_table()
        bm.faces.ensure_lookup_table()
        old = bm.verts[:] if renumbering else None
        faces = [bm.faces[p] for p in it["polys"]]
        region_edges = {e for f in faces for e in f.edges}
        kept = [bm.verts[int(ids[s])] for s in r.boundary_source]
        inner = [bm.verts[int(v)] for v in ids[it["inner"]]]
        sources = [bm.verts[int(v)] for v in ids]  # the chart's vertices, inner ones included
        new = [bm.verts.new(co) for co in r.V[nb:].tolist()]  # before the inner vertices go
        bridge.blend_vertex_groups(new, sources, it["F"][r.source_face[nb:]], r.source_bary[nb:],
                                   bm.verts.layers.deform.active)
        bmesh.ops.delete(bm, geom=faces, context='FACES_ONLY')
        bmesh.ops.delete(bm, geom=inner, context='VERTS')
        vmap = kept + new
        made = [bm.faces.new((vmap[a], vmap[b], vmap[c])) for a, b, c in r.F.tolist()]
        # Old chords of the region (edges between two boundary vertices) that no face uses now.
        stale = [e for e in region_edges if e.is_valid and not e.link_faces]
        if stale:
            bmesh.ops.delete(bm, geom=stale, context='EDGES')
        # The indices to_mesh gives (bmesh reuses freed slots: new faces are not simply appended).
        bm.verts.index_update()
        bm.faces.index_update()
        new_index = None if old is None else np.array([v.index if v.is_valid else -1 for v in old], dtype=np.int64)
        out_index = np.array([v.index for v in vmap], dtype=np.int64)
        polys = np.array([f.index for f in made], dtype=np.int64)
        bm.to_mesh(mesh)
    finally:
        bm.free()
    bridge.write_attributes(mesh, out_index[nb:], points)
    bridge.write_attributes(mesh, polys, face_values)
    _write_new_faces(mesh, polys, out_index[r.F], corner, material, smooth, select_new)
    mesh.update()
    return new_index, out_index


def _write_new_faces(mesh, polys, want, corner, material, smooth, select_new):
    """Corner values ((kind, name), (m, 3[, k])), material index and smooth flag of the new
    triangles ``polys`` whose vertices are ``want`` (m, 3), and (``select_new``) the selection: them
    alone. Each loop's vertex says which corner it is. In bulk: a Python loop per face and corner
    took half of a 100K-vertex Remesh."""
    npoly = len(mesh.polygons)
    loops = bridge.new_face_loops(mesh, polys, want).ravel()
    bridge.write_corners(mesh, loops, corner)
    for key, values in (("material_index", material), ("use_smooth", smooth)):
        a = bridge.get_array(mesh.polygons, key, values.dtype)
        a[polys] = values
        mesh.polygons.foreach_set(key, a)
    if select_new:
        poly = np.zeros(npoly, bool)
        poly[polys] = True
        vert = np.zeros(len(mesh.vertices), bool)
        vert[want.ravel()] = True
        edge = np.zeros(len(mesh.edges), bool)
        edge[bridge.get_array(mesh.loops, "edge_index", np.int32)[loops]] = True
        for coll, sel in ((mesh.polygons, poly), (mesh.vertices, vert), (mesh.edges, edge)):
            coll.foreach_set("select", sel)


def _source_polygons(mesh, it, r):
    """The input polygon each output triangle takes its material, smooth flag and face attributes
    from: the one under most of its corners (each output vertex lies on an input face: source_face),
    so a region across material or shading borders keeps them."""
    mat = bridge.get_array(mesh.polygons, "material_index", np.int32)
    src = np.asarray(r.source_face)
    poly = np.where(src >= 0, it["tri_poly"][np.maximum(src, 0)], it["polys"][0])[np.asarray(r.F)]  # (m, 3)
    m = mat[poly]
    k = np.where((m[:, 0] == m[:, 1]) | (m[:, 0] == m[:, 2]), 0, np.where(m[:, 1] == m[:, 2], 1, 0))
    return poly[np.arange(len(poly)), k]


def _corner_values(mesh, it, r):
    """((kind, name), (m_out, 3[, k]) values of each output triangle's corners) for each layer of
    bridge.corner_layers (UV maps, generic corner attributes, colours included)."""
    L = it["tri_loops"]  # (nf, 3) mesh loops of the chart's triangles
    shared = polymesh.shared_edges(it["F"])
    out = []
    for (kind, name), k in bridge.corner_layers(mesh):
        C = bridge.read_corners(mesh, kind, name, k)[L]
        if C.dtype.kind not in "ib":
            vals = polymesh.island_corners(it["V"], it["F"], C, r, shared)
        else:  # no blend of integers or booleans: the input corner with the largest barycentric weight
            T = r.F
            vals = C[r.source_face[T], np.argmax(r.source_bary[T], axis=-1)]
        out.append(((kind, name), vals[..., 0] if k == 1 else vals))
    return out


classes = (DGMESH_OT_remesh,)
