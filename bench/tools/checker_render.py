"""Blender-side helpers for checker renders of UV maps, side by side (bench unwrap and auto_unwrap).

Imported by scripts that run inside Blender (bench/tools/auto_unwrap_render.py, the unwrap workload's Blender
script): panels of one model laid out along x, seen from -y by an orthographic camera, a checker texture
through the active UV map, Cycles CPU without denoising.
"""

import bpy
import numpy as np


def layout(V):
    """V centred and turned so its largest extent is along x and its smallest along the view (-y), in [-1, 1]."""
    X = V - V.mean(0)
    _, _, R = np.linalg.svd(X, full_matrices=False)
    if np.linalg.det(R) < 0:
        R[2] *= -1
    X = (X @ R.T)[:, [0, 2, 1]] * np.array([1, -1, 1])
    return X / np.abs(X).max()


def checker_material(scale):
    """A Principled material whose base colour is a checker of `scale` squares per UV unit."""
    mat = bpy.data.materials.new("Checker")
    mat.use_nodes = True
    nt = mat.node_tree
    tex = nt.nodes.new("ShaderNodeTexChecker")
    tex.inputs["Scale"].default_value = scale
    uvn = nt.nodes.new("ShaderNodeUVMap")
    nt.links.new(uvn.outputs["UV"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], nt.nodes["Principled BSDF"].inputs["Base Color"])
    return mat


def render_row(scene, panels, path, samples, panel_px):
    """Renders `panels` panels placed 2.2 apart along x into `path` (panel_px = (width, height) of one panel)."""
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2.2 * panels
    cam.location = (2.2 * (panels - 1) / 2, -10, 0)
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
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = panel_px[0] * panels, panel_px[1]
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.view_settings.view_transform = "Standard"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
