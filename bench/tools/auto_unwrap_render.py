"""Checker renders of corner UV maps side by side, for bench workload auto_unwrap (issue 29).

    blender --background --factory-startup --python bench/tools/auto_unwrap_render.py -- IN.npz OUT.png

IN.npz: V (n, 3), F (m, 3) and uv0, uv1, ... ((m, 3, 2) corner UVs: corner k of triangle f), one
panel each, left to right. Every panel's UVs are scaled to the same texel density (UV area = 3D
area) so the checker squares have the same size on all. The model is turned so that its largest
extent is horizontal and its smallest along the view. Cycles CPU, 16 samples, no denoising.
"""

import sys

import bpy
import numpy as np


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    data = np.load(args[0])
    V, F = data["V"], data["F"].astype(np.int32)
    uvs = [data[f"uv{k}"] for k in range(sum(1 for key in data.files if key.startswith("uv")))]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    X = V - V.mean(0)
    _, _, R = np.linalg.svd(X, full_matrices=False)
    if np.linalg.det(R) < 0:
        R[2] *= -1
    X = (X @ R.T)[:, [0, 2, 1]] * np.array([1, -1, 1])  # largest extent along x, viewed from -y
    X /= np.abs(X).max()
    area_x = 0.5 * np.linalg.norm(np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]), axis=1).sum()
    mat = bpy.data.materials.new("Checker")
    mat.use_nodes = True
    nt = mat.node_tree
    tex = nt.nodes.new("ShaderNodeTexChecker")
    tex.inputs["Scale"].default_value = 1.0
    uvn = nt.nodes.new("ShaderNodeUVMap")
    nt.links.new(uvn.outputs["UV"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], nt.nodes["Principled BSDF"].inputs["Base Color"])
    for k, uv in enumerate(uvs):
        mesh = bpy.data.meshes.new(f"panel{k}")
        mesh.vertices.add(len(X))
        mesh.vertices.foreach_set("co", (X + np.array([2.2 * k, 0, 0])).astype(np.float32).ravel())
        mesh.loops.add(3 * len(F))
        mesh.loops.foreach_set("vertex_index", F.ravel())
        mesh.polygons.add(len(F))
        mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
        mesh.polygons.foreach_set("loop_total", np.full(len(F), 3, np.int32))
        mesh.update(calc_edges=True)
        mesh.polygons.foreach_set("use_smooth", np.ones(len(F), bool))
        e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        area_uv = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        # UV area = the panel's 3D area, times 20^2: about 20 checker squares per unit of the panel.
        scale = 20.0 * np.sqrt(area_x / area_uv)
        layer = mesh.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", (uv.reshape(-1, 2) * scale).astype(np.float32).ravel())
        obj = bpy.data.objects.new(f"panel{k}", mesh)
        obj.data.materials.append(mat)
        scene.collection.objects.link(obj)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2.2 * len(uvs)
    cam.location = (2.2 * (len(uvs) - 1) / 2, -10, 0)
    cam.rotation_euler = (np.pi / 2, 0, 0)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.9, 0.2, 0.3)
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.5
    scene.world = world
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 400 * len(uvs), 420
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.view_settings.view_transform = "Standard"
    scene.render.filepath = args[1]
    bpy.ops.render.render(write_still=True)


main()
