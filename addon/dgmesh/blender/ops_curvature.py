"""Operator dgmesh.curvature_map: per-vertex mean and Gaussian curvature.

Several objects: every object is computed first; the valid ones are written
and each failing one gets an ERROR report naming it, with its mesh left
untouched (nothing is written to it).  If none succeeds the operator is
cancelled.  (All-or-nothing would make one broken mesh in a large selection
block the rest, while the reports already say exactly which ones failed.)
Colour ranges are per object, since curvature scales with 1/size.

Modifiers are ignored: attributes live on the original vertices, so the
original mesh datablock is what is measured.
"""

import bpy
import numpy as np
from bpy.props import EnumProperty, FloatProperty

from .. import colors
from . import bridge
from .common import plural as _plural, poll_mesh_targets, read_only_reason, report_shown_shape, target_objects
from .prefs import api

ATTR_MEAN = "dg_mean_curvature"
ATTR_GAUSSIAN = "dg_gaussian_curvature"
ATTR_COLOR = "dg_curvature_color"


class DGMESH_OT_curvature_map(bpy.types.Operator):
    bl_idname = "dgmesh.curvature_map"
    bl_label = "Curvature Map"
    bl_description = (
        "Compute discrete mean and Gaussian curvature per vertex of the selected "
        "meshes (original data, modifiers ignored), store them as point attributes "
        "and show one of them as the active colour attribute"
    )
    bl_options = {'REGISTER', 'UNDO'}

    kind: EnumProperty(
        name="Show",
        description="Which curvature the colour attribute shows",
        items=(
            ('MEAN', "Mean", "Mean curvature H (1/r on a sphere of radius r)"),
            ('GAUSSIAN', "Gaussian", "Gaussian curvature K (1/r\u00b2 on a sphere of radius r)"),
        ),
        default='MEAN',
    )
    percentile: FloatProperty(
        name="Range Percentile",
        description=(
            "The colour range is \u00b1 this percentile of |curvature| of each object; "
            "larger values let fewer extremes saturate"
        ),
        default=95.0,
        min=50.0,
        max=100.0,
        precision=1,
    )

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    def execute(self, context):
        dg = api()
        targets = target_objects(context)
        skipped = 0
        if context.mode == 'OBJECT':
            skipped = sum(1 for o in context.selected_objects if o.type != 'MESH')

        # 1. Compute everything before writing anything.
        results, failures = [], []
        for obj in targets:
            reason = read_only_reason(obj)
            if reason:
                failures.append((obj.name, reason))
                continue
            try:
                arrays = bridge.read_object(obj)
                out = dg.curvature(arrays.V, arrays.F)
                n = arrays.num_vertices
                H = np.asarray(out.mean, dtype=np.float64).reshape(n)
                K = np.asarray(out.gaussian, dtype=np.float64).reshape(n)
            except dg.MeshError as exc:
                failures.append((obj.name, str(exc)))
            except Exception as exc:  # anything else from the native side: report, don't crash
                failures.append((obj.name, f"internal error: {type(exc).__name__}: {exc}"))
            else:
                results.append((obj, H, K))

        # 2. Write the valid ones (Edit mode is left for the writes and re-entered).
        written = []
        if results:
            with bridge.object_mode(context):
                for obj, H, K in results:
                    try:
                        self._write(obj.data, H, K)
                    except Exception as exc:
                        failures.append((obj.name, f"could not write attributes: {type(exc).__name__}: {exc}"))
                    else:
                        written.append((obj, H, K))

        for name, message in failures:
            self.report({'ERROR'}, f"Curvature map failed on '{name}': {message}")
        if not written:
            return {'CANCELLED'}

        self._show_in_viewport(context)
        self.report({'INFO'}, self._summary(written, skipped))
        report_shown_shape(self, [w[0] for w in written])
        return {'FINISHED'}

    def _write(self, mesh, H, K):
        field = H if self.kind == 'MEAN' else K
        rgba = colors.diverging(field, percentile=self.percentile)
        bridge.write_point_float(mesh, ATTR_MEAN, H)
        bridge.write_point_float(mesh, ATTR_GAUSSIAN, K)
        bridge.write_point_color(mesh, ATTR_COLOR, rgba, 'FLOAT_COLOR', make_active=True)

    def _summary(self, written, skipped):
        idx = 1 if self.kind == 'MEAN' else 2
        values = np.concatenate([w[idx] for w in written])
        values = values[np.isfinite(values)]
        lo, hi = (values.min(), values.max()) if values.size else (0.0, 0.0)
        nverts = sum(len(w[0].data.vertices) for w in written)
        label = "mean" if self.kind == 'MEAN' else "Gaussian"
        text = (f"Curvature map on {_plural(len(written), 'object')} ({nverts} vertices): "
                f"{label} curvature range [{lo:.4g}, {hi:.4g}]")
        with_mods = sum(1 for w in written if bridge.mesh_has_modifiers(w[0]))
        if with_mods:
            text += f"; {_plural(with_mods, 'object')} with modifiers: computed on the original mesh"
        if skipped:
            text += f"; skipped {_plural(skipped, 'non-mesh object')}"
        return text

    @staticmethod
    def _show_in_viewport(context):
        # A colour attribute is only visible in Solid shading with Color =
        # Attribute; switch the current 3D view to it (Material Preview and
        # Rendered shading are left alone).
        space = context.space_data
        if getattr(space, "type", None) == 'VIEW_3D' and space.shading.type == 'SOLID':
            space.shading.color_type = 'VERTEX'


classes = (DGMESH_OT_curvature_map,)
