"""Blender side of the limb quality benchmark (run by bench/workloads/skeletal_limb.py through
run_blender): a bone chain, Blender's automatic weights (Parent with Automatic Weights, bone heat),
and Blender's own Armature modifier with linear blend skinning and with Preserve Volume (dual
quaternions) for each pose.

    blender --background --factory-startup --python bench/workloads/_skeletal_limb.py -- IN.npz OUT.npz

IN.npz: V, F (the mesh, object = armature = world space), heads, tails (B x 3, a connected chain
B0 -> B1 -> ...), poses (P x 5: bone index, axis x y z in armature space, angle in radians; the
bone turns about that axis through its head, the others stay at rest).
OUT.npz: W (n x B automatic weights, rows summing to 1; rows Blender left empty get bone 0, which
never moves, so the modifier's result is the same), n_unweighted, rest (B x 4 x 4 bone matrices),
pose{p} (B x 4 x 4), lbs{p}, dqs{p} (n x 3 evaluated positions).
"""

import json
import os
import sys

import bpy
import numpy as np
from mathutils import Matrix, Vector


def main(inp, outp):
    d = np.load(inp)
    V, F = d["V"], d["F"]
    bpy.ops.wm.read_homefile(use_empty=True)
    me = bpy.data.meshes.new("M")
    me.vertices.add(len(V))
    me.vertices.foreach_set("co", V.astype(np.float32).ravel())
    me.loops.add(3 * len(F))
    me.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32))
    me.update(calc_edges=True)
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
    # Parent with Automatic Weights (bone heat), as an artist would; it adds the Armature modifier.
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (obj, arm))
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.parent_set(type='ARMATURE_AUTO')
    mod = next(m for m in obj.modifiers if m.type == 'ARMATURE')
    W = np.zeros((len(V), len(names)))
    col = {obj.vertex_groups[n].index: j for j, n in enumerate(names) if n in obj.vertex_groups}
    for v in obj.data.vertices:
        for g in v.groups:
            j = col.get(g.group)
            if j is not None:
                W[v.index, j] = g.weight
    s = W.sum(1)
    empty = s <= 1e-12
    W[empty, 0] = 1.0
    W /= W.sum(1, keepdims=True)  # the modifier normalises the weights too
    out = {"W": W, "n_unweighted": int(empty.sum()),
           "rest": np.array([np.array(ad.bones[n].matrix_local) for n in names])}
    for p, (j, ax, ay, az, angle) in enumerate(d["poses"]):
        for pb in arm.pose.bones:
            pb.rotation_mode = 'QUATERNION'
            pb.rotation_quaternion = (1, 0, 0, 0)
        pb = arm.pose.bones[names[int(j)]]
        # An armature-space axis through the head, in the bone's rest frame (parents at rest).
        local = ad.bones[names[int(j)]].matrix_local.to_3x3().transposed() @ Vector((ax, ay, az))
        pb.rotation_quaternion = Matrix.Rotation(float(angle), 4, local.normalized()).to_quaternion()
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
            json.dump({"ok": True, "blender": bpy.app.version_string, "n_unweighted": int(empty.sum())}, fh)


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:]
    main(argv[0], argv[1])
