"""Operators dgmesh.fair and dgmesh.regularize (thesis chapter 3).

Fair: Object mode fairs whole objects (mesh-boundary vertices fixed or sliding). Edit mode fairs
the selection: the selected faces are the region (they are refined by Subdivisions), the
selected vertices inside it move, and everything else -- including the border of the selection --
stays, so a patch blends smoothly (position and tangent) into the rest. The hole workflow:
delete faces, fill the hole (F / Alt+F / Grid Fill), keep the new face(s) selected, Fair: a fill
without inner vertices is refined first (Refine Fill, Liepa-style refinement to the mesh's edge
lengths around the hole; on by itself then).

Without subdivision only vertex positions change. With subdivision the selected polygons are
replaced by triangles through bmesh; every other face keeps its data (UVs, colours, attributes),
the new faces copy material and smoothing from the polygon they replace and interpolate its
corner data.

A half modelled with a Mirror modifier (first in the stack, Merge on) is faired or regularized as
the whole it shows: both halves welded at the plane, the base half's part written back with its
seam on the plane (also with Refine Fill and Subdivisions: a hole at the seam blends across it).

Nothing is written before the native run ends: errors and Esc leave the mesh untouched.
"""

import time

import bmesh
import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from .. import polymesh
from ..fairing import FairBoundary, FairMethod, FairOptions, FairScheme, FairStartWeights, RegularizeOptions, refine_region
from ..fairing import defaults as scheme_defaults
from . import bridge
from .common import enum_id, enum_items, poll_mesh_targets, read_only_reason, report_shown_shape, target_objects
from .jobs import NativeJobOperator
from .prefs import api

METHODS = enum_items(FairMethod, {
    "willmore": ("Willmore", "Discrete Willmore flow: minimises the bending energy (integral of H\u00b2); "
                 "spheres stay spheres, patches blend smoothly"),
    "bilaplacian": ("Bilaplacian", "Bi-umbrella flow (thesis comparison flow): simple, flattens more"),
    "laplacian_of_h": ("Laplacian of H", "Laplacian-of-mean-curvature flow (thesis eq. 3.12)"),
    "hinge": ("Hinge Willmore", "Edge-based Willmore energy (dihedral angles) minimised from the bilaplacian "
              "shape; charges a crease along the selection's border at its cost. Needs unselected vertices "
              "(a whole object gets the Willmore flow)"),
})
SCHEMES = enum_items(FairScheme, {
    "semi_implicit": ("Semi-Implicit", "Large stable steps (linearised implicit bi-Laplacian): the same flow, far "
                      "faster, so the same number of iterations goes much further (on a whole object: far from its "
                      "input)"),
    "explicit": ("Explicit", "The thesis's explicit steps (tau = A_min\u00b2/150); slow on fine meshes"),
})
BOUNDARIES = enum_items(FairBoundary, {
    "fixed": ("Fixed", "Open mesh boundaries do not move"),
    "sliding": ("Sliding", "Open mesh boundary vertices slide along the boundary"),
})
START_WEIGHTS = enum_items(FairStartWeights, {
    "uniform": ("Uniform", "The linear start's bi-Laplacian from the connectivity only (uniform bi-umbrella)"),
    "cotangent": ("Cotangent", "The linear start's bi-Laplacian with the cotangent weights of the selection as it "
                  "is (as CGAL's fair): can keep the shape of a dented region, worse on flattened ones"),
})
DEFAULTS = FairOptions()  # property defaults: the library's own (dgmesh/fair.h)
REGULARIZE_DEFAULTS = RegularizeOptions()


def load_scheme_defaults(self, context):
    """Switching the scheme loads its iteration budget (dgmesh.fair's defaults(scheme))."""
    self.max_iterations = scheme_defaults(self.scheme.lower()).max_iterations


class _Target:
    def __init__(self, obj, arrays, mask, faces):
        self.obj = obj
        self.name = obj.name
        self.arrays = arrays
        self.mask = mask  # movable vertices or None
        self.faces = faces  # region triangles or None
        self.refine = False  # Refine Fill for this object (asked for, or a fill without inner vertices)
        # [(axis, merge distance)] of a Mirror modifier, or [] and why it is not used
        self.mirror, self.mirror_unused = bridge.mirror_axes(obj, arrays.V)
        self.result = None


def _read_target(obj, edit_mode, keep_border):
    """Arrays and masks of one object; raises MeshError with a user-facing message. None for an
    edited object with nothing selected (not a target, whatever it holds)."""
    dg = api()
    if edit_mode and not bridge.has_selection(obj):
        return None
    reason = read_only_reason(obj)
    if reason:
        raise dg.MeshError(reason)
    if obj.data.shape_keys is not None:
        # The basis alone would change (the shown shape is the active key's) and Edit mode would
        # bring the keys' positions back.
        raise dg.MeshError("the mesh has shape keys; only the basis would change (remove or apply them first)")
    # Two n-gons sharing a valence-2 vertex (a Grid Fill quad beside a rim quad) can triangulate
    # into the same triangle twice; re-triangulate those instead of reporting duplicate faces.
    arrays = polymesh.repair_ngon_triangles(bridge.read_object(obj, sync=not edit_mode))  # has_selection synced
    if len(arrays.F) == 0:
        raise dg.MeshError("mesh has no faces")
    if not edit_mode:
        return _Target(obj, arrays, None, None)
    mesh = obj.data
    vsel = bridge.get_array(mesh.vertices, "select")
    if not vsel.any():
        return None
    in_face = np.zeros(len(vsel), dtype=bool)
    in_face[arrays.F.ravel()] = True
    if not (vsel & in_face).any():
        raise dg.MeshError("the selected vertices are in no face (loose vertices or wire edges): select the faces "
                           "to fair")
    psel = bridge.get_array(mesh.polygons, "select")
    tri_sel = psel[arrays.tri_poly]
    movable = vsel & in_face  # a loose vertex has nothing to be faired with
    if keep_border:
        # Vertices of unselected faces are the border: they stay, with the ring beyond them.
        touched = np.zeros(len(vsel), dtype=bool)
        touched[arrays.F[~tri_sel].ravel()] = True
        movable &= ~touched
    faces = tri_sel if tri_sel.any() else None
    if faces is None and not movable.any():
        raise dg.MeshError("every selected vertex touches an unselected face, which keeps it fixed: select the "
                           "faces to fair (or turn off Keep Selection Border)")
    if faces is not None:
        arrays = polymesh.orient_region(arrays, tri_sel)
    return _Target(obj, arrays, movable, faces)


class _FairBase(NativeJobOperator):
    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def collect_targets(self, context):
        edit = context.mode == 'EDIT_MESH'
        targets, failures = [], []
        for obj in target_objects(context):
            try:
                t = _read_target(obj, edit, getattr(self, "keep_border", True))
            except api().MeshError as exc:
                failures.append((obj.name, str(exc)))
                continue
            if t is not None:
                targets.append(t)
        for name, msg in failures:
            self.report({'ERROR'}, f"{self.bl_label} failed on '{name}': {msg}")
        if not targets:
            if not failures:
                self.report({'ERROR'}, f"{self.bl_label}: nothing selected (select vertices or faces in Edit mode)")
            return None
        return targets

    def prepare(self, context):
        targets = self.collect_targets(context)
        if targets is None:
            return None
        self._t0 = time.perf_counter()
        self._auto_refined = []
        can_refine = hasattr(self, "refine")  # Fair has Refine Fill, Regularize does not
        for t in targets:
            t.refine = can_refine and self.refine and t.faces is not None
            # A hole just filled (Fill / F) has no inner vertex to move: without subdivisions the
            # flow could do nothing, and subdividing the fill's long triangles 1-to-4 leaves the
            # flow slivers to balloon (a triangle fan over a polar cap rose to twice the sphere's
            # radius), so the fill is refined (Liepa) as the workflow needs; the redo panel then
            # shows Refine Fill on.
            if can_refine and not t.refine and t.faces is not None and not t.mask.any():
                t.refine = True
                self._auto_refined.append(t.name)
        if self._auto_refined:
            self.refine = True

        def work(progress):
            n = len(targets)
            for i, t in enumerate(targets):
                def sub(f, i=i):
                    return progress((i + f) / n)
                try:
                    t.result = self.run_mirrored(t, sub)
                except api().MeshError as exc:  # name the object: several may be selected
                    raise api().MeshError(f"'{t.name}': {exc}") from None
            return targets

        return work

    def run_mirrored(self, t, progress):
        """_run on the mesh the Mirror modifier shows (both halves welded), so the halves meet
        smoothly at the plane instead of the base half's rim being held fixed (flat into it); the
        base half's part of the result. Refine Fill refines the half first (the welded whole's
        refinement would not be symmetric); Subdivisions split the welded whole, whose seam edges'
        midpoints both halves share."""
        V0, F0, n0 = t.arrays.V, t.arrays.F, len(t.arrays.V)
        V1, F1, mask1, faces1, origin1 = V0, F0, t.mask, t.faces, None
        refined = False
        if t.mirror and t.refine:
            Vs, Fs, faces_s, origin_s = polymesh.split_seam_edges(V0, F0, t.faces, t.mirror)
            V1, F1, origin1 = refine_region(Vs, Fs, faces_s)
            refined = len(V1) > len(Vs)
            mask1 = np.concatenate([t.mask, np.ones(len(V1) - n0, bool)])
            faces1 = faces_s[origin1]
            origin1 = origin_s[origin1]
        m = polymesh.mirrored(V1, F1, (mask1, faces1), t.mirror) if t.mirror else None
        t.mirrored = m is not None
        if m is None:
            return self.run_target(t, V0, F0, t.mask, t.faces, t.refine, progress)
        V, F, (mask, faces) = m
        # As the native Refine Fill does: a fill the refinement gave no inner vertex (a small hole; at
        # most the plane's edge was split) is subdivided once.
        levels = 1 if t.refine and not refined else None
        r = self.run_target(t, V, F, mask, faces, False, progress, levels)
        n1, m1 = len(V1), len(F1)
        if isinstance(r, np.ndarray):  # Regularize: positions
            return polymesh.on_mirror_planes(r[:n1].copy(), V0, t.mirror)
        # The half's faces: its rows (row f holds a child of input face f) and the extra children of
        # its faces; its vertices: its own, then the new ones its faces use (never a mirror copy).
        rows = np.flatnonzero(r.face_origin < m1)
        Fh = r.faces[rows]
        new = np.unique(Fh[Fh >= len(V)])
        index = np.full(len(r.vertices), -1)
        index[:n1] = np.arange(n1)
        index[new] = n1 + np.arange(len(new))
        Fh = index[Fh]
        if (Fh < 0).any():  # cannot happen: the flow neither flips nor joins faces across the plane
            raise api().MeshError("the mirrored result could not be split into its halves")
        Vh = polymesh.on_mirror_planes(np.concatenate([r.vertices[:n1], r.vertices[new]]), V1, t.mirror)
        size = float(np.ptp(V0, axis=0).max())
        for k, _tol in t.mirror:  # a seam edge's midpoint is on the plane up to rounding
            near = np.abs(Vh[n1:, k]) <= 1e-9 * size
            Vh[n1:, k][near] = 0.0
        origin = r.face_origin[rows] if origin1 is None else origin1[r.face_origin[rows]]
        return r.replace(vertices=Vh, faces=Fh, face_origin=origin.astype(np.int32),
                         moved=np.concatenate([r.moved[:n1], r.moved[new]]))


class DGMESH_OT_fair(_FairBase, bpy.types.Operator):
    bl_idname = "dgmesh.fair"
    bl_label = "Fair"
    bl_description = (
        "Fair the mesh by a curvature flow (discrete Willmore flow by default): whole objects in "
        "Object mode, the selection in Edit mode (its border stays fixed, so a filled hole blends "
        "smoothly into the surface)"
    )
    bl_options = {'REGISTER', 'UNDO'}

    method: EnumProperty(name="Method", items=METHODS, default=enum_id(DEFAULTS.method))
    scheme: EnumProperty(name="Scheme", items=SCHEMES, default=enum_id(DEFAULTS.scheme), update=load_scheme_defaults)
    subdivisions: IntProperty(
        name="Subdivisions", default=DEFAULTS.subdivisions, min=0, max=4,
        description="Coarse-to-fine levels: fair, subdivide the region 1-to-4, fair again")
    tolerance: FloatProperty(
        name="Tolerance", default=DEFAULTS.tolerance, min=1e-9, max=0.1, precision=6,
        description="Stop when the relative change of the bending energy falls below this")
    max_iterations: IntProperty(
        name="Max Iterations", default=DEFAULTS.max_iterations, min=1, max=100000, soft_max=3000,
        description="Iteration budget per subdivision level (switching the scheme loads its default)")
    boundary: EnumProperty(name="Boundary", items=BOUNDARIES, default=enum_id(DEFAULTS.boundary))
    tangential: BoolProperty(
        name="Even Out Triangles", default=DEFAULTS.tangential,
        description="Add the tangential drift that keeps triangles regular (thesis eq. 3.8)")
    keep_size: BoolProperty(
        name="Keep Size", default=DEFAULTS.keep_size,
        description="Willmore, Laplacian of H: a closed part faired whole keeps its place and surface area "
        "(the bending energy does not depend on them, so only the shape changes)")
    keep_border: BoolProperty(
        name="Keep Selection Border", default=True,
        description="Edit mode: vertices on the border of the selection stay fixed")
    linear_start: BoolProperty(
        name="Linear Start", default=DEFAULTS.linear_start,
        description="With fixed vertices, Willmore and Laplacian of H first jump to the bilaplacian "
        "solution (when that lowers the bending energy) and flow from there; a flat fill alone "
        "can keep a crease along the hole's rim")
    start_weights: EnumProperty(name="Start Weights", items=START_WEIGHTS, default=enum_id(DEFAULTS.start_weights))
    # SKIP_SAVE: turned on by itself for a fill without inner vertices, it must not stay on for the
    # next Fair (a Grid Fill with inner vertices would be re-triangulated).
    refine: BoolProperty(
        name="Refine Fill", default=DEFAULTS.refine, options={'SKIP_SAVE'},
        description="Edit mode: first refine the selected faces to triangles sized like the mesh "
        "around them (Liepa's hole filling: a fill without inner vertices is first re-triangulated "
        "by the minimum-weight triangulation of its rim, then centroid splits and Delaunay flips). For "
        "a hole filled with Fill (one n-gon or a fan) or a coarse Grid Fill; the selection's border "
        "edges are not split. Turned on by itself when the selected faces have no inner vertex to "
        "move")

    def draw(self, context):
        self.layout.use_property_split = True  # as the other operators' redo panels
        col = self.layout.column()
        for p in ("method", "scheme", "subdivisions", "tolerance", "max_iterations", "boundary", "tangential",
                  "linear_start", "start_weights"):
            col.prop(self, p)
        if self.method != 'BILAPLACIAN':
            col.prop(self, "keep_size")
        if context.mode == 'EDIT_MESH':
            col.prop(self, "keep_border")
            col.prop(self, "refine")

    def run_target(self, t, V, F, mask, faces, refine, progress, levels=None):
        return api().fair(
            V, F, method=self.method.lower(), mask=mask, faces=faces,
            boundary=self.boundary.lower(), subdivisions=max(self.subdivisions, levels or 0), tolerance=self.tolerance,
            max_iterations=self.max_iterations, tangential=self.tangential, scheme=self.scheme.lower(),
            linear_start=self.linear_start, start_weights=self.start_weights.lower(), refine=refine, keep_size=self.keep_size, progress=progress)

    def finish(self, context, targets):
        written, failures = [], []
        edit = context.mode == 'EDIT_MESH'
        with bridge.object_mode(context):
            for t in targets:
                try:
                    if t.result.subdivided:
                        _write_subdivided(t, select=edit)
                    else:
                        bridge.write_positions(t.obj.data, t.result.vertices)
                except Exception as exc:  # leave other objects written, report this one
                    failures.append((t.name, f"could not write the result: {type(exc).__name__}: {exc}"))
                else:
                    written.append(t)
        for name, msg in failures:
            self.report({'ERROR'}, f"Fair failed on '{name}': {msg}")
        if not written:
            return {'CANCELLED'}
        secs = time.perf_counter() - self._t0
        parts, level = [], 'INFO'
        for t in written:
            r = t.result
            e0, e1 = float(r.energy[0]), float(r.energy[-1])
            n = len(t.arrays.V)
            moved = polymesh.moved_count(r.vertices[:n], t.arrays.V)
            stall = r.stall.name
            if stall != "none":
                # Never a silent no-op (issue 30): say that the flow did not change the region, why,
                # and what helps.
                level = 'WARNING'
                status = (" (nothing moved: " if stall == "no_descent" else
                          " (the bending energy did not go down: ")
                status += ("the selection is already at the bilaplacian flow's steady state; try Willmore)"
                           if self.method == 'BILAPLACIAN' else
                           "the flow cannot lower the bending energy from the start, a minimum of the discrete "
                           "energy at this resolution (e.g. a flattened patch whose crease along the fixed border "
                           "costs little); select a larger region, turn on Refine or Subdivisions, or use the "
                           "Bilaplacian method)")
            elif r.energy_rose and self.method == 'BILAPLACIAN':
                level = 'WARNING'
                status = (" (the bilaplacian flow shrinks a closed part towards a point: its lowest-energy state "
                          "was kept; use Willmore to fair closed parts)")
            elif r.energy_rose:
                level = 'WARNING'
                status = (" (the flow raised the bending energy and kept its lowest-energy state: already faired, "
                          "or slivers / fan-triangulated n-gons? Triangulate with Beauty or Regularize first)")
            elif r.converged:
                status = ""
            elif len(r.level_iterations) and r.level_iterations[-1] >= self.max_iterations:
                status = " (iteration budget reached)"
            else:
                status = " (stopped before the tolerance: the flow stalled)"
            if r.start_fallback:
                # Never a silent substitution: the cotangent start was asked for and not used.
                level = 'WARNING'
                status += (" (Start Weights Cotangent could not be used: a closed part is faired whole, a vertex next "
                           "to the selection has no area, or the cotangent system could not be solved; the Uniform "
                           "start was used instead)")
            if r.restarted:
                status += (" (restarted from the linear start: the flow from the selection stalled at a minimum of "
                           "the discrete energy; the result may end above its energy)")
            mods = _modifier_note(t)
            energy = f"bending energy {e0:.4g} \u2192 {e1:.4g}"
            levels = r.level_iterations
            if len(levels) > 1 and 0 < levels[0] < len(r.energy):
                # Each subdivision raises the discrete energy (flat facets): the first level's end and
                # the refined mesh's end are the comparable figures, not the input's and the output's.
                energy = (f"bending energy {e0:.4g} \u2192 {float(r.energy[levels[0]]):.4g}, then {e1:.4g} "
                          f"on the mesh subdivided {len(levels) - 1}x")
            parts.append(
                f"'{t.name}'{mods}: {moved} vertices moved"
                + (f", {len(r.vertices) - n} added" if r.subdivided else "")
                + f", {r.iterations} iterations, {energy}" + status)
        note = (" (Refine Fill on: the selected faces had no inner vertex to move)"
                if getattr(self, "_auto_refined", None) else "")
        self.report({level}, f"Fair ({self.method.title().replace('_', ' ')}) in {secs:.2f} s: " + "; ".join(parts)
                    + note)
        report_shown_shape(self, [t.obj for t in written])
        return {'FINISHED'}


def _modifier_note(t):
    """' (its base mesh, before Mirror, Subdivision)' when modifiers change what the user sees
    (' (both halves of its Mirror)' when the mirrored mesh was faired)."""
    names = [m.type.title().replace("_", " ") for m in t.obj.modifiers if m.show_viewport]
    if getattr(t, "mirrored", False):
        return " (both halves of its Mirror" + (f"; before {', '.join(names[1:4])})" if names[1:] else ")")
    why = getattr(t, "mirror_unused", "")
    if why is None:  # usable, but not used: a fill face lies in the plane
        why = "a face lies in its plane"
    return (f" (its base mesh, before {', '.join(names[:3])}" + (f"; the Mirror is not used: {why}" if why else "")
            + ")") if names else ""


def _write_subdivided(t, select):
    """Replace the refined polygons by the output triangles with bmesh; other faces untouched."""
    mesh = t.obj.data
    r = t.result
    V, F, origin = r.vertices, r.faces, r.face_origin
    n_old = len(t.arrays.V)
    tri_poly = t.arrays.tri_poly
    m = len(t.arrays.F)
    # Input triangles that were split have extra children (rows >= m); their polygons are
    # replaced whole, so the rows of the polygons' other triangles come along.
    refined = np.zeros(m, dtype=bool)
    refined[origin[m:]] = True
    refined |= np.any(F[:m] != t.arrays.F, axis=1)  # rows rewritten by Refine Fill's edge flips
    polys = np.unique(tri_poly[refined])
    poly_of_row = tri_poly[origin]
    rows = np.flatnonzero(np.isin(poly_of_row, polys))

    # The replaced polygons' corners and corner data, read before bmesh renumbers the loops.
    layers = [(key, bridge.read_corners(mesh, *key, k)) for key, k in bridge.corner_layers(mesh)]
    loop_start = bridge.get_array(mesh.polygons, "loop_start", np.int32).astype(np.int64)
    loop_total = bridge.get_array(mesh.polygons, "loop_total", np.int32).astype(np.int64)
    loop_vertex = bridge.get_array(mesh.loops, "vertex_index", np.int32)
    points = bridge.read_attributes(mesh, 'POINT')

    bm = bmesh.new()
    try:
        bm.from_mesh(mesh)
        bm.verts.ensure_lookup_table()
        bm.faces.ensure_lookup_table()
        moved = np.flatnonzero(r.moved[:n_old])
        for i in moved:
            bm.verts[i].co = V[i]
        verts = list(bm.verts)
        for co in V[n_old:].tolist():
            verts.append(bm.verts.new(co))
        bm.verts.index_update()
        by_poly = {int(p): bm.faces[int(p)] for p in polys}
        old_faces = list(by_poly.values())
        deform = bm.verts.layers.deform.active
        # New vertices: inverse fourth-power distance weights over the replaced polygons' vertices
        # (Shepard interpolation over the hole's rim: a fill's flips make the polygon a new vertex
        # was traced to a poor guide).
        src = list({v for f in old_faces for v in f.verts})
        new_points = []
        if len(V) > n_old and src and (points or deform is not None):
            Q = np.array([v.co[:] for v in src])
            idx = polymesh.nearest_sources(Q, V[n_old:], knn=bridge.kd_nearest)
            d2 = ((V[n_old:, None, :] - Q[idx]) ** 2).sum(-1)
            W = 1.0 / np.maximum(d2, 1e-300) ** 2
            W /= W.sum(1, keepdims=True)
            new_points = polymesh.blend_attributes(points, np.array([v.index for v in src])[idx], W)
            bridge.blend_vertex_groups(verts[n_old:], src, idx, W, deform)
        # Faces one by one (bmesh has no bulk creation); their corner data and selection are
        # written in bulk after to_mesh, by the indices bmesh gives them.
        made, made_rows, kept = [], [], set()
        old_set = set(old_faces)
        for row in rows.tolist():
            fv = [verts[k] for k in F[row]]
            same = bm.faces.get(fv)
            if same is not None and same in old_set:
                # An input triangle the refinement kept (a fill triangle its flips restored): keep
                # the face itself rather than a second one on the same vertices.
                kept.add(same)
                continue
            made.append(bm.faces.new(fv, by_poly[int(poly_of_row[row])]))  # example face: material, smooth
            made_rows.append(row)
        old_faces = [f for f in old_faces if f not in kept]
        old_edges = {e for f in old_faces for e in f.edges}
        bmesh.ops.delete(bm, geom=old_faces, context='FACES_ONLY')
        # Edges of the old polygons that were split now have no face: remove them.
        loose = [e for e in old_edges if e.is_valid and not e.link_faces]
        if loose:
            bmesh.ops.delete(bm, geom=loose, context='EDGES')
        bm.verts.index_update()
        bm.faces.index_update()
        vindex = np.array([v.index for v in verts], dtype=np.int64)
        made_polys = np.array([f.index for f in made], dtype=np.int64)
        kept_polys = np.array([f.index for f in kept], dtype=np.int64)
        bm.normal_update()
        bm.to_mesh(mesh)
    finally:
        bm.free()
    bridge.write_attributes(mesh, vindex[n_old:], new_points)
    made_rows = np.array(made_rows, dtype=np.int64)
    if len(made_rows):
        loops = bridge.new_face_loops(mesh, made_polys, vindex[F[made_rows]])
        if layers:
            corner = polymesh.interpolate_corners(V, F[made_rows], poly_of_row[made_rows], loop_start, loop_total,
                                                  loop_vertex, layers)
            bridge.write_corners(mesh, loops, corner)
    _select_faces(mesh, np.concatenate([made_polys, kept_polys]), select)
    mesh.update()


def _select_faces(mesh, polys, select):
    """Selects (or deselects) the faces ``polys`` with their edges and vertices, as bmesh's
    face.select does; other elements keep their state."""
    if not len(polys):
        return
    start = bridge.get_array(mesh.polygons, "loop_start", np.int32).astype(np.int64)[polys]
    total = bridge.get_array(mesh.polygons, "loop_total", np.int32).astype(np.int64)[polys]
    loops = polymesh.ranges(start, total)
    for coll, idx in ((mesh.polygons, polys),
                      (mesh.edges, bridge.get_array(mesh.loops, "edge_index", np.int32)[loops]),
                      (mesh.vertices, bridge.get_array(mesh.loops, "vertex_index", np.int32)[loops])):
        sel = bridge.get_array(coll, "select", bool)
        sel[idx] = select
        coll.foreach_set("select", sel)


class DGMESH_OT_regularize(_FairBase, bpy.types.Operator):
    bl_idname = "dgmesh.regularize"
    bl_label = "Regularize"
    bl_description = (
        "Even out triangle sizes and shapes by sliding vertices along the surface (tangential "
        "drift of the thesis, eq. 3.8 with no normal motion): the selection in Edit mode, whole "
        "objects in Object mode"
    )
    bl_options = {'REGISTER', 'UNDO'}

    iterations: IntProperty(name="Iterations", default=REGULARIZE_DEFAULTS.iterations, min=1, max=100000,
                            soft_max=1000)
    boundary: EnumProperty(name="Boundary", items=BOUNDARIES, default=enum_id(REGULARIZE_DEFAULTS.boundary))
    strength: FloatProperty(
        name="Step", default=REGULARIZE_DEFAULTS.step_scale, min=0.01, max=4.0,
        description="Multiplies the thesis's step (12 times the smallest triangle area, taken within two "
                    "rings of each vertex)")
    keep_on_surface: BoolProperty(
        name="Keep on Surface", default=REGULARIZE_DEFAULTS.project,
        description="Project moved vertices back onto the original surface after each step")
    keep_border: BoolProperty(
        name="Keep Selection Border", default=False,
        description="Edit mode: vertices on the border of the selection stay fixed")

    def draw(self, context):
        self.layout.use_property_split = True
        col = self.layout.column()
        for p in ("iterations", "boundary", "strength", "keep_on_surface"):
            col.prop(self, p)
        if context.mode == 'EDIT_MESH':
            col.prop(self, "keep_border")

    def run_target(self, t, V, F, mask, faces, refine, progress, levels=None):
        V = api().regularize(V, F, iterations=self.iterations, mask=mask,
                             boundary=self.boundary.lower(), step_scale=self.strength,
                             project=self.keep_on_surface, progress=progress)
        return V

    def finish(self, context, targets):
        with bridge.object_mode(context):
            for t in targets:
                bridge.write_positions(t.obj.data, t.result)
        moved = sum(polymesh.moved_count(t.result, t.arrays.V) for t in targets)
        secs = time.perf_counter() - self._t0
        mods = "".join(_modifier_note(t) for t in targets[:1])
        self.report({'INFO'}, f"Regularize: {moved} vertices moved on {len(targets)} object(s){mods}, "
                              f"{self.iterations} iterations in {secs:.2f} s")
        report_shown_shape(self, [t.obj for t in targets])
        return {'FINISHED'}


classes = (DGMESH_OT_fair, DGMESH_OT_regularize)
