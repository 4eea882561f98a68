"""Operator dgmesh.multires_preview: the displaced-subdivision control mesh of the active object.

Builds :class:`dgmesh.Multires` for the active mesh (original data, modifiers ignored): the coarse
control mesh appears as a separate wireframe object ("<name>_control", same transform, replaced on
re-runs), and the dense mesh gets the displacement from the Loop limit surface of the control mesh
as attributes: ``dg_multires_displacement`` (FLOAT, signed distance along the limit normal, the DSS
scalar), ``dg_multires_magnitude`` (FLOAT, |x - S|) and the colour attribute
``dg_multires_color`` (the magnitude, viridis). Vertex positions, topology, UVs, groups and every
other attribute of the dense mesh are left as they are. On an error nothing is changed.
"""

import time

import bpy
import numpy as np
from bpy.props import FloatProperty, IntProperty

from .. import colors
from . import bridge
from .common import poll_fail as _poll_fail
from .prefs import api

ATTR_DISP = "dg_multires_displacement"
ATTR_MAG = "dg_multires_magnitude"
ATTR_COLOR = "dg_multires_color"
CONTROL_KEY = "dgmesh_multires_control_of"  # custom property on the control object


class _Progress:
    """Native progress callback driving the window manager's progress indicator (if any)."""

    def __init__(self, context):
        self.wm = context.window_manager if context.window is not None else None
        if self.wm:
            self.wm.progress_begin(0, 100)

    def __call__(self, fraction):
        if self.wm:
            self.wm.progress_update(int(100 * fraction))
        return True

    def end(self):
        if self.wm:
            self.wm.progress_end()


def _control_object(context, obj, V, F):
    """Creates or replaces the wireframe control object of `obj`."""
    name = f"{obj.name}_control"
    ctrl = next((o for o in bpy.data.objects if o.get(CONTROL_KEY) == obj.name and o.type == 'MESH'), None)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(V, dtype=np.float64).tolist(), [], np.asarray(F).tolist())  # small
    mesh.update(calc_edges=True)
    if ctrl is None:
        ctrl = bpy.data.objects.new(name, mesh)
        collections = obj.users_collection or (context.scene.collection,)
        for col in collections:
            col.objects.link(ctrl)
        ctrl[CONTROL_KEY] = obj.name
    else:
        old = ctrl.data
        ctrl.data = mesh
        if old.users == 0:
            bpy.data.meshes.remove(old)
    ctrl.matrix_world = obj.matrix_world.copy()
    ctrl.display_type = 'WIRE'
    ctrl.show_in_front = True
    return ctrl


class DGMESH_OT_multires_preview(bpy.types.Operator):
    bl_idname = "dgmesh.multires_preview"
    bl_label = "Multires Preview"
    bl_description = (
        "Build the displaced-subdivision representation of the active mesh: show its coarse "
        "control mesh as a wireframe object and the displacement from the control mesh's Loop "
        "limit surface as a colour attribute (the mesh itself is not moved)"
    )
    bl_options = {'REGISTER', 'UNDO'}

    control_faces: IntProperty(
        name="Control Faces", description="Target face count of the decimated control mesh",
        default=5000, min=4, soft_max=20000)
    level: IntProperty(
        name="Level", description="Adaptive isolation level of the limit patches (1-5)",
        default=2, min=1, max=5)
    fit_iterations: IntProperty(
        name="Fit Iterations",
        description="Least-squares fits of the control mesh to the dense mesh (0: plain decimation)",
        default=1, min=0, max=5)
    min_quality: FloatProperty(
        name="Sliver Guard", description="Minimum triangle quality kept by the decimation (1 = equilateral)",
        default=0.2, min=0.0, max=0.9)
    percentile: FloatProperty(
        name="Range Percentile", description="The colour range ends at this percentile of the magnitude",
        default=95.0, min=50.0, max=100.0)

    @classmethod
    def poll(cls, context):
        if context.mode != 'OBJECT':
            return _poll_fail(cls, "Only available in Object mode")
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            return _poll_fail(cls, "The active object must be a mesh")
        return True

    def execute(self, context):
        dg = api()
        obj = context.active_object
        if obj.data.library is not None:
            self.report({'ERROR'}, f"Multires preview failed on '{obj.name}': mesh data is linked from a library")
            return {'CANCELLED'}
        progress = _Progress(context)
        t0 = time.perf_counter()
        try:
            arrays = bridge.read_object(obj)
            mr = dg.Multires.build(arrays.V, arrays.F, control_faces=self.control_faces, level=self.level,
                                   min_quality=self.min_quality, fit_iterations=self.fit_iterations,
                                   progress=progress)
            rest = mr.reconstruct(mr.control_vertices)
        except dg.Cancelled:
            self.report({'WARNING'}, "Multires preview cancelled; nothing was changed")
            return {'CANCELLED'}
        except dg.MeshError as exc:
            self.report({'ERROR'}, f"Multires preview failed on '{obj.name}': {exc}")
            return {'CANCELLED'}
        except Exception as exc:  # anything else from the native side: report, don't crash
            self.report({'ERROR'}, f"Multires preview failed on '{obj.name}': internal error: "
                                   f"{type(exc).__name__}: {exc}")
            return {'CANCELLED'}
        finally:
            progress.end()
        seconds = time.perf_counter() - t0

        disp = mr.normal_displacement
        mag = mr.displacement_magnitude
        mesh = obj.data
        bridge.write_point_float(mesh, ATTR_DISP, disp)
        bridge.write_point_float(mesh, ATTR_MAG, mag)
        bridge.write_point_color(mesh, ATTR_COLOR, colors.sequential(mag, percentile=self.percentile),
                                 'FLOAT_COLOR', make_active=True)
        ctrl = _control_object(context, obj, mr.control_vertices, mr.control_faces)

        V = arrays.V
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
        return {'FINISHED'}


classes = (DGMESH_OT_multires_preview,)
