"""Blender side of the skeletal quality benchmark (run by bench/workloads/skeletal.py through
run_blender): Blender's own Armature modifier, linear blend and Preserve Volume.

    blender --background --factory-startup --python bench/workloads/_skeletal_blender.py -- IN.npz OUT.npz

IN.npz: V, F (the mesh), heads, tails (B x 3: a chain of connected bones B0 -> B1 -> ...), W (n x B
weights), poses (P x 3 Euler angles, mode YXZ, of the last bone).
OUT.npz: rest (B x 4 x 4 bone matrices, armature = object space), pose{p} (B x 4 x 4), lbs{p},
dqs{p} (n x 3 evaluated positions).
"""

import json
import os
import sys

import bpy
import numpy as np


def main(inp, outp):
    d = np.load(inp)
    V, F, W = d["V"], d["F"], d["W"]
    bpy.ops.wm.read_homefile(use_empty=True)
    me = bpy.data.meshes.new("M")
    me.vertices.add(len(V))
    me.vertices.foreach_set("co", V.astype(np.float32).ravel())
    me.loops.add(3 * len(F))
    me.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32))
    me.update()
    obj = bpy.data.objects.new("M", me)
    bpy.context.scene.collection.objects.link(obj)
    ad = bpy.data.armatures.new("Rig")
    arm = bpy.data.objects.new("Rig", ad)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    names = [f"B{j}" for j in range(len(d["heads"]))]
    prev = None
    for j, name in enumerate(names):
        b = ad.edit_bones.new(name)
        b.head, b.tail = tuple(d["heads"][j]), tuple(d["tails"][j])
        if prev is not None:
            b.parent, b.use_connect = prev, True
        prev = b
    bpy.ops.object.mode_set(mode='OBJECT')
    for j, name in enumerate(names):
        g = obj.vertex_groups.new(name=name)
        for i in np.nonzero(W[:, j] > 0)[0]:
            g.add([int(i)], float(W[i, j]), 'REPLACE')
    mod = obj.modifiers.new("Armature", 'ARMATURE')
    mod.object = arm
    out = {"rest": np.array([np.array(ad.bones[n].matrix_local) for n in names])}
    pb = arm.pose.bones[names[-1]]
    pb.rotation_mode = 'YXZ'
    for p, e in enumerate(d["poses"]):
        pb.rotation_euler = tuple(float(x) for x in e)
        for key, pv in (("lbs", False), ("dqs", True)):
            mod.use_deform_preserve_volume = pv
            bpy.context.view_layer.update()
            dg = bpy.context.evaluated_depsgraph_get()
            ev = obj.evaluated_get(dg)
            m = ev.to_mesh()
            co = np.empty(3 * len(m.vertices), dtype=np.float32)
            m.vertices.foreach_get("co", co)
            ev.to_mesh_clear()
            out[f"{key}{p}"] = co.reshape(-1, 3).astype(np.float64)
        out[f"pose{p}"] = np.array([np.array(arm.pose.bones[n].matrix) for n in names])
    np.savez(outp, **out)
    res = os.environ.get("DGMESH_BENCH_OUT")
    if res:
        with open(res, "w") as fh:
            json.dump({"ok": True, "blender": bpy.app.version_string}, fh)


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:]
    main(argv[0], argv[1])
