"""Blender side of the crest-line renders (run by bench/workloads/crest.py through run_blender).

    blender --background --factory-startup --python bench/workloads/_crest_render.py -- IN.npz OUT.png

IN.npz holds panels laid out side by side (left to right): panel i has V{i}, F{i} and optionally
C{i} (per-face RGB, linear), W{i} (draw the triangle edges), P{i}/O{i}/K{i} (polyline points,
offsets, kind 0 ridge / 1 valley). Also 'up' ('Y' or 'Z'), 'size' (w, h), 'samples', 'view'
(camera direction). Cycles CPU, no denoising, Standard view transform.
"""

import json
import math
import os
import sys

import bpy
import numpy as np
from mathutils import Vector

RIDGE = (0.05, 0.15, 1.0)
VALLEY = (1.0, 0.05, 0.05)


def mesh_object(name, V, F, face_rgb=None):
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", V.astype(np.float32).ravel())
    mesh.loops.add(3 * len(F))
    mesh.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    mesh.polygons.add(len(F))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    mesh.polygons.foreach_set("use_smooth", np.full(len(F), face_rgb is None))
    mat = bpy.data.materials.new(name + "_mat")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 0.7
    spec = bsdf.inputs.get("Specular") or bsdf.inputs.get("Specular IOR Level")
    if spec is not None:
        spec.default_value = 0.15
    if face_rgb is None:
        bsdf.inputs["Base Color"].default_value = (0.75, 0.75, 0.72, 1.0)
    else:
        rgba = np.ones((len(F) * 3, 4), dtype=np.float32)
        rgba[:, :3] = np.repeat(face_rgb, 3, axis=0)
        mesh.color_attributes.new("seg", 'FLOAT_COLOR', 'CORNER')
        mesh.attributes["seg"].data.foreach_set("color", rgba.ravel())
        attr = mat.node_tree.nodes.new("ShaderNodeAttribute")
        attr.attribute_name = "seg"
        mat.node_tree.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def emission(name, rgb, strength=1.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    em = nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (*rgb, 1.0)
    em.inputs["Strength"].default_value = strength
    mat.node_tree.links.new(em.outputs["Emission"], out.inputs["Surface"])
    return mat


def wire_object(name, V, F, radius):
    """The triangle edges as a thin dark tube mesh (Wireframe modifier on a copy)."""
    obj = mesh_object(name, V, F)
    obj.data.materials.clear()
    obj.data.materials.append(emission(name + "_wire", (0.02, 0.02, 0.02)))
    mod = obj.modifiers.new("wire", 'WIREFRAME')
    mod.thickness = radius
    mod.use_replace = True
    mod.use_even_offset = False
    return obj


def curve_object(name, P, O, K, radius):
    curve = bpy.data.curves.new(name, 'CURVE')
    curve.dimensions = '3D'
    curve.bevel_depth = radius
    curve.bevel_resolution = 1
    curve.materials.append(emission(name + "_r", RIDGE, 1.5))
    curve.materials.append(emission(name + "_v", VALLEY, 1.5))
    for i in range(len(O) - 1):
        pts = P[O[i]:O[i + 1]]
        if len(pts) < 2:
            continue
        s = curve.splines.new('POLY')
        s.points.add(len(pts) - 1)
        co = np.ones((len(pts), 4), dtype=np.float32)
        co[:, :3] = pts
        s.points.foreach_set("co", co.ravel())
        s.material_index = int(K[i])
    obj = bpy.data.objects.new(name, curve)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def main(inp, outp):
    d = np.load(inp, allow_pickle=False)
    meta = json.loads(str(d["meta"]))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    n = meta["panels"]
    up = meta.get("up", "Z")
    rot = np.eye(3)
    if up == "Y":  # y-up model -> z-up
        rot = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)
    spin = math.radians(meta.get("spin", 0.0))
    rz = np.array([[math.cos(spin), -math.sin(spin), 0], [math.sin(spin), math.cos(spin), 0], [0, 0, 1]])
    rot = rz @ rot
    Vs = [d[f"V{i}"] @ rot.T for i in range(n)]
    lo = np.min([V.min(0) for V in Vs], axis=0)
    hi = np.max([V.max(0) for V in Vs], axis=0)
    diag = float(np.linalg.norm(hi - lo))
    width = hi[0] - lo[0]
    gap = meta.get("gap", 0.08) * width
    all_pts = []
    for i in range(n):
        shift = np.array([i * (width + gap) - Vs[i].mean(0)[0], -Vs[i].mean(0)[1], -lo[2]])
        V = Vs[i] + shift
        all_pts.append(V)
        C = d[f"C{i}"] if f"C{i}" in d else None
        mesh_object(f"panel{i}", V, d[f"F{i}"], C)
        if f"W{i}" in d:
            wire_object(f"wire{i}", V, d[f"F{i}"], meta.get("wire", 0.0012) * diag)
        if f"P{i}" in d:
            P = d[f"P{i}"] @ rot.T + shift
            curve_object(f"lines{i}", P, d[f"O{i}"], d[f"K{i}"], meta.get("line", 0.0025) * diag)

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50
    scene.collection.objects.link(cam)
    scene.camera = cam
    w, h = meta.get("size", (480, 360))
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    direction = Vector(meta.get("view", (0.0, -1.0, 0.25))).normalized()
    cam.rotation_euler = (-direction).to_track_quat('-Z', 'Y').to_euler()
    pts = np.concatenate(all_pts)
    pts = pts[:: max(1, len(pts) // 20000)]
    loc, _ = cam.camera_fit_coords(bpy.context.evaluated_depsgraph_get(), pts.ravel().tolist())
    cam.location = loc + direction * (0.03 * diag)

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 3.0
    sun.data.angle = math.radians(15)
    sun.rotation_euler = (-(direction + Vector((0.4, 0.0, 0.8)))).normalized().to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 0.6
    scene.world = world

    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = int(meta.get("samples", 16))
    scene.cycles.use_denoising = False
    # A wider pixel filter and one diffuse bounce: less noise at 16 samples, smaller PNGs.
    scene.cycles.filter_width = 2.0
    scene.cycles.max_bounces = 2
    scene.cycles.diffuse_bounces = 1
    scene.view_settings.view_transform = 'Standard'
    scene.render.image_settings.file_format = 'PNG'
    scene.render.image_settings.color_mode = 'RGB'
    scene.render.image_settings.compression = 100
    scene.render.filepath = outp
    bpy.ops.render.render(write_still=True)
    out = os.environ.get("DGMESH_BENCH_OUT")
    if out:
        with open(out, "w") as fh:
            json.dump({"image": outp, "blender": bpy.app.version_string}, fh)


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:]
    main(argv[0], argv[1])
