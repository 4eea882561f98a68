"""Operator dgmesh.multires_preview: the displaced-subdivision control mesh of the active object.

Builds :class:`dgmesh.Multires` for the active mesh (original data, modifiers ignored): the coarse
control mesh appears as a separate wireframe object ("<name>_control", same transform, replaced on
re-runs), and the dense mesh gets the displacement from the Loop limit surface of the control mesh
as attributes: ``dg_multires_displacement`` (FLOAT, signed distance along the limit normal, the DSS
scalar), ``dg_multires_magnitude`` (FLOAT, |x - S|) and the colour attribute
``dg_multires_color`` (the magnitude, viridis). Vertex positions, topology, UVs, groups and every
other attribute of the dense mesh are left as they are. On an error nothing is changed.

Started from the UI, the build runs in a worker thread (jobs.NativeJobOperator: progress in the
status bar, Esc cancels and nothing is written); from scripts and in ``--background`` execute()
runs it in a row, and setting :data:`cancel_event` cancels it the same way.
"""

import threading
import time

import bpy
import numpy as np
from bpy.props import FloatProperty, IntProperty
from mathutils import Matrix

from .. import colors
from ..multires import MultiresOptions
from . import bridge
from .common import editable_collection, poll_active_mesh, read_only_reason, report_shown_shape
from .jobs import NativeJobOperator
from .prefs import api

ATTR_DISP = "dg_multires_displacement"
ATTR_MAG = "dg_multires_magnitude"
ATTR_COLOR = "dg_multires_color"
CONTROL_KEY = "dgmesh_multires_control_of"  # custom property on the control object
# A cancel request for scripts (Esc does the same in an interactive run): the progress callback then
# returns False, the native build raises Cancelled and nothing is written. Cleared when a run ends.
cancel_event = threading.Event()
DEFAULTS = MultiresOptions()  # property defaults: the library's own (dgmesh/multires.h)


def make_work(V, F, **options):
    """The native part of the preview as ``work(progress) -> (Multires, rest positions, seconds)``:
    numpy and dgmesh only (it runs in a worker thread when interactive). ``options``: keywords of
    :meth:`dgmesh.Multires.build` (its defaults otherwise). ``progress`` is fraction -> bool; False
    (or :data:`cancel_event`) cancels with dgmesh.Cancelled."""
    dg = api()

    def work(progress):
        t0 = time.perf_counter()
        try:
            mr = dg.Multires.build(V, F, **options,
                                   progress=lambda f: bool(progress(f)) and not cancel_event.is_set())
            rest = mr.reconstruct(mr.control_vertices)
        finally:
            cancel_event.clear()
        return mr, rest, time.perf_counter() - t0

    return work


def _control_object(context, obj, V, F):
    """Creates or replaces the wireframe control object of `obj`."""
    name = f"{obj.name}_control"
    # The control object points at its mesh object (an ID pointer follows renames; files from
    # before hold the name).
    ctrl = next((o for o in bpy.data.objects if o.type == 'MESH' and o.get(CONTROL_KEY) in (obj, obj.name)), None)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(V, dtype=np.float64).tolist(), [], np.asarray(F).tolist())  # small
    mesh.update(calc_edges=True)
    if ctrl is None:
        ctrl = bpy.data.objects.new(name, mesh)
        editable_collection(context, obj).objects.link(ctrl)
        ctrl[CONTROL_KEY] = obj
    else:
        old = ctrl.data
        ctrl.data = mesh
        if old.users == 0:
            bpy.data.meshes.remove(old)
    # A child with an identity local transform: on the mesh (a copied matrix_world loses a parent's
    # shear) and following it.
    ctrl.parent = obj
    ctrl.matrix_parent_inverse = Matrix.Identity(4)
    ctrl.matrix_basis = Matrix.Identity(4)
    ctrl.display_type = 'WIRE'
    ctrl.show_in_front = True
    return ctrl


class DGMESH_OT_multires_preview(NativeJobOperator, bpy.types.Operator):
    bl_idname = "dgmesh.multires_preview"
    bl_label = "Multires Preview"
    bl_description = (
        "Build the displaced-subdivision representation of the active mesh: show its coarse "
        "control mesh as a wireframe object and the displacement from the control mesh's Loop "
        "limit surface as a colour attribute (the mesh itself is not moved). Esc cancels long runs"
    )
    bl_options = {'REGISTER', 'UNDO'}

    control_faces: IntProperty(
        name="Control Faces", description="Target face count of the decimated control mesh",
        default=DEFAULTS.control_faces, min=4, soft_max=20000)
    level: IntProperty(
        name="Level", description="Adaptive isolation level of the limit patches (1-5)",
        default=DEFAULTS.level, min=1, max=5)
    fit_iterations: IntProperty(
        name="Fit Iterations",
        description="Least-squares fits of the control mesh to the dense mesh (0: plain decimation)",
        default=DEFAULTS.fit_iterations, min=0, max=5)
    min_quality: FloatProperty(
        name="Sliver Guard", description="Minimum triangle quality kept by the decimation (1 = equilateral)",
        default=DEFAULTS.min_quality, min=0.0, max=0.9)
    percentile: FloatProperty(
        name="Range Percentile", description="The colour range ends at this percentile of the magnitude",
        default=95.0, min=50.0, max=100.0)

    @classmethod
    def poll(cls, context):
        return poll_active_mesh(cls, context)

    def prepare(self, context):
        """Reads the active mesh (main thread); returns the native work, or None after an error."""
        obj = context.active_object
        reason = read_only_reason(obj)
        if reason:
            self.report({'ERROR'}, f"Multires preview failed on '{obj.name}': {reason}")
            cancel_event.clear()
            return None
        self._name = obj.name
        try:
            self._arrays = bridge.read_object(obj)
        except Exception as exc:  # reported like a native error; nothing was changed
            cancel_event.clear()
            self.report_failure(exc)
            return None
        return make_work(self._arrays.V, self._arrays.F, control_faces=self.control_faces, level=self.level,
                         min_quality=self.min_quality, fit_iterations=self.fit_iterations)

    def report_failure(self, exc):
        dg = api()
        if isinstance(exc, dg.MeshError) and not isinstance(exc, dg.Cancelled):
            self.report({'ERROR'}, f"Multires preview failed on '{self._name}': {exc}")
            return {'CANCELLED'}
        if not isinstance(exc, dg.Cancelled):
            self.report({'ERROR'}, f"Multires preview failed on '{self._name}': internal error: "
                                   f"{type(exc).__name__}: {exc}")
            return {'CANCELLED'}
        return super().report_failure(exc)

    def finish(self, context, result):
        """Writes the attributes and the control object (main thread) and reports."""
        mr, rest, seconds = result
        obj = bpy.data.objects.get(self._name)
        if obj is None or obj.type != 'MESH' or len(obj.data.vertices) != mr.n_dense:
            self.report({'ERROR'}, f"Multires preview: '{self._name}' changed while the build ran; nothing was written")
            return {'CANCELLED'}
        ctrl = _control_object(context, obj, mr.control_vertices, mr.control_faces)  # first: it may fail
        disp = mr.normal_displacement
        mag = mr.displacement_magnitude
        mesh = obj.data
        bridge.write_point_float(mesh, ATTR_DISP, disp)
        bridge.write_point_float(mesh, ATTR_MAG, mag)
        bridge.write_point_color(mesh, ATTR_COLOR, colors.sequential(mag, percentile=self.percentile),
                                 'FLOAT_COLOR', make_active=True)

        V = self._arrays.V
        diag = float(np.linalg.norm(V.max(0) - V.min(0))) or 1.0
        rest_err = float(np.abs(rest - V).max()) / diag
        space = context.space_data
        if getattr(space, "type", None) == 'VIEW_3D' and space.shading.type == 'SOLID':
            space.shading.color_type = 'VERTEX'
        self.report({'INFO'}, (
            f"Multires preview of '{obj.name}': {mr.n_dense} vertices bound to '{ctrl.name}' "
            f"({len(mr.control_faces)} faces, {mr.n_control} vertices) in {seconds:.2f} s; "
            f"|displacement| max {mag.max():.4g}, RMS {np.sqrt((mag ** 2).mean()):.4g}; "
            f"rest reconstruction error {rest_err:.1e} of the diagonal"))
        report_shown_shape(self, [obj])
        if len(mr.control_faces) > 1.5 * self.control_faces:
            self.report({'WARNING'}, f"The control mesh has {len(mr.control_faces)} faces, more than the "
                        f"{self.control_faces} asked: the decimation stops where a collapse would change the "
                        "topology, fold the surface or leave a sliver")
        return {'FINISHED'}


classes = (DGMESH_OT_multires_preview,)
