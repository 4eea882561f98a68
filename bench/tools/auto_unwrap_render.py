"""Checker renders of corner UV maps side by side, for bench workload auto_unwrap (issue 29).

    blender --background --factory-startup --python bench/tools/auto_unwrap_render.py -- IN.npz OUT.png

IN.npz: V (n, 3), F (m, 3) and uv0, uv1, ... ((m, 3, 2) corner UVs: corner k of triangle f), one
panel each, left to right. Every panel's UVs are scaled to the same texel density (UV area = 3D
area) so the checker squares have the same size on all. The model is turned so that its largest
extent is horizontal and its smallest along the view. Cycles CPU, 16 samples, no denoising.
"""

import pathlib
import sys

import bpy
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from blender_uv_peer import add_object  # noqa: E402
from checker_render import checker_material, layout, render_row  # noqa: E402


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    data = np.load(args[0])
    V, F = data["V"], data["F"].astype(np.int32)
    uvs = [data[f"uv{k}"] for k in range(sum(1 for key in data.files if key.startswith("uv")))]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    X = layout(V)
    area_x = 0.5 * np.linalg.norm(np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]), axis=1).sum()
    mat = checker_material(1.0)
    for k, uv in enumerate(uvs):
        mesh = add_object(f"panel{k}", X + np.array([2.2 * k, 0, 0]), F).data
        mesh.polygons.foreach_set("use_smooth", np.ones(len(F), bool))
        e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        area_uv = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        # UV area = the panel's 3D area, times 20^2: about 20 checker squares per unit of the panel.
        scale = 20.0 * np.sqrt(area_x / area_uv)
        mesh.uv_layers["UVMap"].data.foreach_set("uv", (uv.reshape(-1, 2) * scale).astype(np.float32).ravel())
        mesh.materials.append(mat)
    render_row(scene, len(uvs), args[1], 16, (400, 420))


if __name__ == "__main__":
    main()
