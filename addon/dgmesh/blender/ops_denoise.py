"""Operators dgmesh.denoise and dgmesh.similarity_map (thesis chapter 2).

dgmesh.denoise works on every selected mesh object in Object mode, and on the selected vertices of
the edited objects in Edit mode (the other vertices stay put but still inform the filter). Meshes
with quads and n-gons are triangulated for the computation only (Blender's own loop triangles);
triangle soups work as they are (coincident vertices move together); meshes without faces are
point clouds and need a FLOAT_VECTOR point attribute ``Normal`` (Blender 3.4 reserves ``normal``
for its own normals and will not make one; ``normal`` from an import, ``normals`` and ``N`` are read
as well).

Everything is computed before anything is written: an object that fails gets an ERROR report and
is left untouched; a cancelled run (Esc, or a progress callback returning False) writes nothing.
Started from the UI, the native work runs in a worker thread (jobs.NativeJobOperator: progress in
the status bar, Esc cancels); from scripts and in ``--background`` execute() runs it in a row.
"""

import threading
import time

import bmesh
import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from .. import colors, polymesh
from ..denoising import DenoiseMethod, DenoiseOptions, SimilarityOptions
from ..denoising import defaults as method_defaults
from . import bridge
from .common import (enum_id, enum_items, plural as _plural, poll_active_mesh, poll_mesh_targets, read_only_reason, report_shown_shape,
                     target_objects)
from .jobs import NativeJobOperator
from .prefs import api

ATTR_RESIDUAL = "dg_denoise_residual"
ATTR_RESIDUAL_COLOR = "dg_denoise_residual_color"
ATTR_SIMILARITY = "dg_similarity"
ATTR_SIMILARITY_COLOR = "dg_similarity_color"
NORMAL_ATTRIBUTE = "Normal"  # the name messages ask for: Blender 3.4 reserves "normal" (new() gives None)
NORMAL_ATTRIBUTE_ALIASES = ("normal", "Normal", "normals", "N")
# A cancel request for scripts (Esc does the same in an interactive run): the progress callback then
# returns False, the native code raises Cancelled and nothing is written. Cleared when a run ends.
cancel_event = threading.Event()

METHOD_ITEMS = enum_items(DenoiseMethod, {
    "similarity": ("Similarity", "Non-local means with RBF patches (thesis ch. 2): best at keeping features"),
    "bilateral": ("Bilateral", "Bilateral mesh denoising (Fleishman et al. 2003): faster, rounds sharp edges"),
})
DEFAULTS = DenoiseOptions()  # property defaults: the library's own (dgmesh/denoise.h)
SIMILARITY_DEFAULTS = SimilarityOptions()


def read_point_normals(mesh):
    """The FLOAT_VECTOR point attribute ``Normal`` (or normal, normals, N) as (n, 3) float64, or None."""
    for name in NORMAL_ATTRIBUTE_ALIASES:
        attr = mesh.attributes.get(name)
        if attr is not None and attr.data_type == 'FLOAT_VECTOR' and attr.domain == 'POINT':
            break
    else:
        return None
    buf = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    attr.data.foreach_get("vector", buf)
    return buf.reshape(-1, 3).astype(np.float64)


class _Job:
    """One object's input (read on the main thread) and result (computed anywhere)."""

    def __init__(self, obj, V, F, N, mask):
        self.obj, self.name = obj, obj.name
        self.V, self.F, self.N, self.mask = V, F, N, mask
        # A half modelled with a Mirror modifier: its vertices on the mirror planes stay there, so
        # the halves stay welded (denoising moves them off by up to the noise level).
        self.mirror, self.mirror_unused = bridge.mirror_axes(obj, V)
        self.result = None
        self.error = None


def _read_job(obj, edit_mode):
    """A _Job for obj, an error message, or None (Edit mode, nothing selected in it)."""
    mesh = obj.data
    if edit_mode and not bridge.has_selection(obj):
        return None
    reason = read_only_reason(obj)
    if reason:
        return reason
    if mesh.shape_keys is not None:
        return "the mesh has shape keys; denoising would only change the basis (remove or apply them first)"
    if len(mesh.vertices) == 0:
        return "the mesh is empty"
    arrays = bridge.read_object(obj, sync=not edit_mode)  # has_selection synced the edit-mesh
    mask = None
    if edit_mode:
        mask = bridge.get_array(mesh.vertices, "select") & ~bridge.get_array(mesh.vertices, "hide")
        if not mask.any():
            return None  # nothing selected in this one of the edited objects
    if len(arrays.F) == 0:
        N = read_point_normals(mesh)
        if N is None:
            return (f"the mesh has no faces; to denoise it as a point cloud give it a FLOAT_VECTOR "
                    f"point attribute '{NORMAL_ATTRIBUTE}'")
        return _Job(obj, arrays.V, None, N, mask)
    return _Job(obj, arrays.V, arrays.F, None, mask)


def load_method_defaults(self, context):
    """Switching the method loads its defaults (thesis table 2.1 / section 2.3)."""
    d = method_defaults(self.method.lower())
    self.eta1, self.eta2, self.eta3, self.iterations = d.eta1, d.eta2, d.eta3, d.iterations


def _show_colors(context):
    # Colour attributes only show in Solid shading with Color = Attribute.
    space = context.space_data
    if getattr(space, "type", None) == 'VIEW_3D' and space.shading.type == 'SOLID':
        space.shading.color_type = 'VERTEX'


class DGMESH_OT_denoise(NativeJobOperator, bpy.types.Operator):
    bl_idname = "dgmesh.denoise"
    bl_label = "Denoise"
    bl_description = (
        "Remove noise from the selected meshes, triangle soups or point clouds (point attribute 'Normal') "
        "while keeping sharp features: similarity-based non-local means (thesis ch. 2) or bilateral "
        "filtering. In Edit mode only the selected vertices move. Esc cancels long runs"
    )
    bl_options = {'REGISTER', 'UNDO'}

    method: EnumProperty(name="Method", items=METHOD_ITEMS, default=enum_id(DEFAULTS.method), update=load_method_defaults)
    automatic: BoolProperty(
        name="Auto",
        description=("Estimate the noise of each mesh and choose the similarity kernel, the iterations and "
                     "the quadratic fit from it (the etas below then only set the neighbourhood sizes); "
                     "similarity on meshes: Taubin smoothing instead where the filtered mesh shows no sharp "
                     "features and the estimate asks for it"),
        default=DEFAULTS.automatic,
    )
    eta1: FloatProperty(
        name="Similarity \u03b71",
        description=("Similarity: deviation of the similarity kernel (about the noise level); bilateral: "
                     "deviation of the height kernel. In units of the average edge length"),
        default=DEFAULTS.eta1, min=0.01, soft_max=2.0, max=20.0, step=5, precision=3,
    )
    eta2: FloatProperty(
        name="Domain \u03b72",
        description="Half the radius of the averaging neighbourhood, in average edge lengths",
        default=DEFAULTS.eta2, min=0.1, soft_max=4.0, max=20.0, step=10, precision=2,
    )
    eta3: FloatProperty(
        name="Patch \u03b73",
        description=("Similarity: half the radius of the compared patches; bilateral: deviation of the "
                     "spatial kernel. In average edge lengths"),
        default=DEFAULTS.eta3, min=0.1, soft_max=4.0, max=20.0, step=10, precision=2,
    )
    iterations: IntProperty(name="Iterations", default=DEFAULTS.iterations, min=0, soft_max=10, max=100)
    quadratic_fit: BoolProperty(
        name="Quadratic Fit",
        description=("Similarity: move each vertex to a similarity-weighted quadratic fitted to its neighbours "
                     "instead of their weighted mean height, so that curvature is not flattened"),
        default=DEFAULTS.quadratic_fit,
    )
    show_residual: BoolProperty(
        name="Show Residual",
        description=(f"Store |x_noisy - x_smoothed| per vertex as '{ATTR_RESIDUAL}' and show it as the "
                     f"colour attribute '{ATTR_RESIDUAL_COLOR}'"),
        default=False,
    )

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "method")
        layout.prop(self, "automatic")
        for name in ("eta1", "eta2", "eta3", "iterations", "quadratic_fit"):
            row = layout.row()
            row.active = not self.automatic or name in ("eta2", "eta3")  # auto chooses the others
            row.prop(self, name)
        layout.prop(self, "show_residual")

    # --- running (jobs.NativeJobOperator) -------------------------------------------------------

    def prepare(self, context):
        """Reads every target (main thread); returns work(progress) or None after reporting."""
        edit_mode = context.mode == 'EDIT_MESH'
        jobs, failures = [], []
        for obj in target_objects(context):
            try:
                job = _read_job(obj, edit_mode)
            except Exception as exc:  # reading must never take Blender down
                job = f"could not read the mesh: {type(exc).__name__}: {exc}"
            if isinstance(job, str):
                failures.append((obj.name, job))
            elif job is not None:
                jobs.append(job)
        if not jobs and not failures:
            self.report({'ERROR'}, "Denoise: no vertices selected")
            cancel_event.clear()
            return None
        if not jobs:
            for name, message in failures:
                self.report({'ERROR'}, f"Denoise failed on '{name}': {message}")
            cancel_event.clear()
            return None
        method = self.method.lower()
        etas = dict(automatic=self.automatic, eta1=self.eta1, eta2=self.eta2, eta3=self.eta3,
                    iterations=self.iterations, quadratic_fit=self.quadratic_fit)
        t0 = time.perf_counter()

        def work(progress):
            """Any thread; numpy and dgmesh only. Raises Cancelled when asked to stop."""
            dg = api()
            total = sum(len(j.V) for j in jobs)
            done = 0
            try:
                for job in jobs:
                    lo, span = done / total, len(job.V) / total

                    def cb(f, lo=lo, span=span):
                        return bool(progress(lo + span * f)) and not cancel_event.is_set()

                    try:
                        job.result = dg.denoise(job.V, job.F, job.N, method=method, mask=job.mask,
                                                progress=cb, **etas)
                    except dg.MeshError as exc:
                        job.error = str(exc)
                    done += len(job.V)
            finally:
                cancel_event.clear()
            return jobs, failures, time.perf_counter() - t0

        return work

    def finish(self, context, result):
        """Writes the results (main thread) and reports."""
        jobs, failures, seconds = result
        failures = failures + [(j.name, j.error) for j in jobs if j.error is not None]
        ok = [j for j in jobs if j.result is not None]
        written = []
        if ok:
            with bridge.object_mode(context):
                for job in ok:
                    try:
                        self._write(job)
                    except Exception as exc:
                        failures.append((job.name, f"could not write the result: {type(exc).__name__}: {exc}"))
                    else:
                        written.append(job)
        for name, message in failures:
            self.report({'ERROR'}, f"Denoise failed on '{name}': {message}")
        if not written:
            return {'CANCELLED'}
        if self.show_residual:
            _show_colors(context)
        self.report({'INFO'}, self._summary(written, seconds))
        report_shown_shape(self, [job.obj for job in written])
        for job in written:
            if job.mirror_unused:  # a Mirror it cannot honour: its seam may open
                self.report({'WARNING'}, f"'{job.name}': the Mirror modifier is not used ({job.mirror_unused}): "
                                         "vertices on its plane may have moved off it")
        return {'FINISHED'}

    def _write(self, job):
        mesh = job.obj.data
        bridge.write_positions(mesh, polymesh.on_mirror_planes(np.array(job.result.vertices), job.V, job.mirror))
        if self.show_residual:
            residual = job.result.residual
            bridge.write_point_float(mesh, ATTR_RESIDUAL, residual)
            bridge.write_point_color(mesh, ATTR_RESIDUAL_COLOR, colors.sequential(residual), 'FLOAT_COLOR',
                                     make_active=True)

    def _summary(self, written, seconds):
        nverts = sum(len(j.V) for j in written)
        moved = sum(int((j.result.residual > 0).sum()) for j in written)
        H = [j.result.residual_entropy for j in written]
        entropy = f"{H[0]:.3f} bits" if len(H) == 1 else f"{min(H):.3f}-{max(H):.3f} bits (per object)"
        clouds = sum(1 for j in written if j.F is None)
        welded = sum(1 for j in written if j.result.welded)
        # What ran per object: the filter, or (automatic mode on meshes) Taubin smoothing instead, or nothing.
        def ran_on(r):
            if r.options.smoothing_steps and not r.iterations:
                return f"Taubin smoothing, {_plural(r.options.smoothing_steps, 'step')}"
            if self.automatic and not r.iterations:
                return "nothing (Auto found no noise to remove)"
            return f"{self.method.lower()}, {_plural(r.iterations, 'iteration')}"
        ran = sorted({ran_on(j.result) for j in written})
        text = (f"Denoised {_plural(len(written), 'object')} ({nverts} vertices, {moved} moved) with "
                f"{' / '.join(ran)}{' (per object)' if len(ran) > 1 else ''}, "
                f"in {seconds:.2f} s; residual entropy {entropy}")
        if self.automatic:
            sig = [j.result.noise.sigma for j in written]
            noise = (f"{sig[0]:.3f}" if len(sig) == 1 else f"{min(sig):.3f}-{max(sig):.3f}")
            eta1 = [j.result.options.eta1 for j in written]
            text += (f"; estimated noise {noise} edge lengths (auto: \u03b71 "
                     f"{eta1[0]:.3f}" + ("" if len(eta1) == 1 else f"-{max(eta1):.3f}") + ")")
        if clouds:
            text += f"; {_plural(clouds, 'point cloud')}"
        if welded:
            text += f"; coincident vertices moved together on {_plural(welded, 'object')}"
        return text


def _active_vertex(obj):
    """Index of the active vertex in Edit mode; in edge or face select mode, the vertex of the active
    element nearest its centre; else the first selected vertex; else None."""
    bm = bmesh.from_edit_mesh(obj.data)
    bm.verts.index_update()
    active = bm.select_history.active
    if isinstance(active, bmesh.types.BMVert):
        return active.index
    if isinstance(active, (bmesh.types.BMEdge, bmesh.types.BMFace)):
        verts = list(active.verts)
        centre = sum((v.co for v in verts), verts[0].co * 0) / len(verts)
        return min(verts, key=lambda v: (v.co - centre).length).index
    for v in bm.verts:
        if v.select:
            return v.index
    return None


class DGMESH_OT_similarity_map(NativeJobOperator, bpy.types.Operator):
    bl_idname = "dgmesh.similarity_map"
    bl_label = "Similarity Map"
    bl_description = (
        "Colour the active mesh by the similarity of every vertex's neighbourhood to that of the active "
        "vertex (Edit mode) or of the chosen vertex index (Object mode): white = different, blue = "
        "similar (thesis fig. 2.1c)"
    )
    bl_options = {'REGISTER', 'UNDO'}

    vertex: IntProperty(
        name="Vertex",
        description="Vertex index to compare with (Object mode; Edit mode uses the active vertex, or a "
        "vertex of the active edge or face)",
        default=0, min=0,
    )
    mode: EnumProperty(
        name="Compare",
        items=(
            ('SHAPE', "Shape", "Similar shapes anywhere on the model, however tilted"),
            ('FILTER', "Filter Weights", "The denoising filter's own weights (vanish away from the vertex)"),
        ),
        default='SHAPE',
    )
    eta1: FloatProperty(name="Similarity \u03b71", default=SIMILARITY_DEFAULTS.eta1, min=0.01, soft_max=2.0, max=20.0, precision=3,
                        description="Deviation of the similarity kernel, in average edge lengths")
    eta3: FloatProperty(name="Patch \u03b73", default=SIMILARITY_DEFAULTS.eta3, min=0.1, soft_max=4.0, max=20.0, precision=2,
                        description="Half the radius of the compared patches, in average edge lengths")

    @classmethod
    def poll(cls, context):
        return poll_active_mesh(cls, context, edit_mode=True)

    def prepare(self, context):
        """Reads the active mesh (main thread); returns work(progress) or None after reporting."""
        dg = api()
        obj = context.active_object
        reason = read_only_reason(obj)
        if reason:
            self.report({'ERROR'}, f"Similarity map failed on '{obj.name}': {reason}")
            return None
        vertex = self.vertex
        if obj.mode == 'EDIT':
            active = _active_vertex(obj)
            if active is None:
                self.report({'ERROR'}, "Similarity map: select a vertex (the active one is compared)")
                return None
            vertex = active
        try:
            arrays = bridge.read_object(obj)
            F, N = arrays.F, None
            bad = np.flatnonzero(~np.isfinite(arrays.V).all(axis=1))
            if len(bad):  # (the native check, in the job, cannot name the object)
                raise dg.MeshError(f"{len(bad)} vertex coordinate(s) are NaN or infinite (first: vertex {bad[0]})")
            if len(F) == 0:
                F, N = None, read_point_normals(obj.data)
                if N is None:
                    raise dg.MeshError(f"the mesh has no faces and no FLOAT_VECTOR point attribute "
                                       f"'{NORMAL_ATTRIBUTE}'")
        except Exception as exc:  # reading must never take Blender down
            detail = str(exc) if isinstance(exc, dg.MeshError) else f"internal error: {type(exc).__name__}: {exc}"
            self.report({'ERROR'}, f"Similarity map failed on '{obj.name}': {detail}")
            return None
        self._target = (obj.name, vertex)
        V, eta1, eta3, mode = arrays.V, self.eta1, self.eta3, self.mode.lower()

        def work(progress):
            """Any thread; numpy and dgmesh only."""
            return dg.similarity(V, F, vertex, N, eta1=eta1, eta3=eta3, mode=mode, progress=progress)

        return work

    def finish(self, context, w):
        name, vertex = self._target
        obj = bpy.data.objects.get(name)
        if obj is None or obj.type != 'MESH' or len(obj.data.vertices) != len(w):
            self.report({'ERROR'}, f"Similarity map: '{name}' changed while it was running: nothing was written")
            return {'CANCELLED'}
        mesh = obj.data
        with bridge.object_mode(context):
            bridge.write_point_float(mesh, ATTR_SIMILARITY, w)
            # The diverging palette's negative half runs from near-white (0) to deep blue (1).
            bridge.write_point_color(mesh, ATTR_SIMILARITY_COLOR, colors.diverging(-w, limit=1.0), 'FLOAT_COLOR',
                                     make_active=True)
        _show_colors(context)
        self.report({'INFO'}, (f"Similarity map of '{obj.name}' to vertex {vertex}: "
                               f"{int((w > 0.5).sum())} of {len(w)} vertices above 0.5"))
        report_shown_shape(self, [obj])
        return {'FINISHED'}


classes = (DGMESH_OT_denoise, DGMESH_OT_similarity_map)
