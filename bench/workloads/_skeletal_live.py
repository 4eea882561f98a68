"""Blender side of the skeletal speed benchmark: bind a Loop-subdivided capsule with the operator,
then time scene.frame_set over keyframed poses (the live update through the shape key).

    blender --background --factory-startup --python bench/workloads/_skeletal_live.py -- LEVELS
"""
import json
import math
import os
import pathlib
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))
import dgmesh
from dgmesh.skeletal import capsule
from bench.common import loop_subdivide
dgmesh.register()
bpy.ops.wm.read_homefile(use_empty=True)
V0, F0 = capsule(0.5, 6.0, 80, 10, 120)
V, F = loop_subdivide(V0, F0, int(sys.argv[sys.argv.index("--") + 1]))  # noqa: E501
me = bpy.data.meshes.new("C")
me.vertices.add(len(V)); me.vertices.foreach_set("co", V.astype(np.float32).ravel())
me.loops.add(3 * len(F)); me.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
me.polygons.add(len(F)); me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
me.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32)); me.update()
obj = bpy.data.objects.new("C", me); bpy.context.scene.collection.objects.link(obj)
ad = bpy.data.armatures.new("Rig"); arm = bpy.data.objects.new("Rig", ad); bpy.context.scene.collection.objects.link(arm)
bpy.context.view_layer.objects.active = arm
bpy.ops.object.mode_set(mode='EDIT')
b1 = ad.edit_bones.new("Upper"); b1.head, b1.tail = (-3.5, 0, 0), (0, 0, 0)
b2 = ad.edit_bones.new("Lower"); b2.head, b2.tail = (0, 0, 0), (3.5, 0, 0); b2.parent = b1; b2.use_connect = True
bpy.ops.object.mode_set(mode='OBJECT')
for o in bpy.context.view_layer.objects: o.select_set(o in (obj, arm))
bpy.context.view_layer.objects.active = obj
t0 = time.perf_counter(); r = bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT', control_faces=5000); tb = time.perf_counter() - t0
pb = arm.pose.bones["Lower"]
pb.rotation_mode = 'XYZ'
for fr, a in ((1, 0.0), (40, math.pi / 2)):
    pb.rotation_euler = (0, 0, a)
    pb.keyframe_insert("rotation_euler", frame=fr)
from dgmesh.blender import ops_skeletal  # noqa: E402
deform_t = []
_orig = ops_skeletal._deformed


def _timed(o, pose):
    t0 = time.perf_counter()
    res = _orig(o, pose)
    deform_t.append(time.perf_counter() - t0)
    return res


ops_skeletal._deformed = _timed
sc = bpy.context.scene
ts = []
for fr in range(2, 22):
    t0 = time.perf_counter()
    sc.frame_set(fr)
    ts.append(time.perf_counter() - t0)
with open(os.environ["DGMESH_BENCH_OUT"], "w") as fh:
    json.dump({"V": len(V), "bind_s": tb, "bind_result": sorted(r), "frame_ms": 1e3 * float(np.median(ts)),
               "deform_ms": 1e3 * float(np.median(deform_t)), "n_deform": len(deform_t), "n_frames": len(ts)}, fh)
