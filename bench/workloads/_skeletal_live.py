"""Blender side of the skeletal live-update benchmark: bind a Loop-subdivided capsule with the
operator, then time scene.frame_set over keyframed poses (the live update through the hidden helper
object read by the geometry-nodes modifier), split into its parts, against the previous live target
(the offset attribute on the mesh itself, block-interleaved on the same object) and Blender's own
Armature modifier on the same mesh and frames.

    blender --background --factory-startup --python bench/workloads/_skeletal_live.py -- LEVELS [FRAMES]

Writes JSON to $DGMESH_BENCH_OUT. Wall-clock medians in ms; *_cpu_ms are CPU seconds of the whole
Blender process (all threads) per frame, which a loaded machine inflates less than wall time.
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
import dgmesh  # noqa: E402
from dgmesh.skeletal import capsule  # noqa: E402
from bench.common import loop_subdivide  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
LEVELS = int(argv[0])
NFRAMES = int(argv[1]) if len(argv) > 1 else 20
dgmesh.register()
from dgmesh.blender import skeletal_live, skeletal_store  # noqa: E402
from dgmesh.blender.common import set_handlers  # noqa: E402

bpy.ops.wm.read_homefile(use_empty=True)
V0, F0 = capsule(0.5, 6.0, 80, 10, 120)
V, F = loop_subdivide(V0, F0, LEVELS)
me = bpy.data.meshes.new("C")
me.vertices.add(len(V))
me.vertices.foreach_set("co", V.astype(np.float32).ravel())
me.loops.add(3 * len(F))
me.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
me.polygons.add(len(F))
me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
me.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32))
me.update(calc_edges=True)
obj = bpy.data.objects.new("C", me)
bpy.context.scene.collection.objects.link(obj)
ad = bpy.data.armatures.new("Rig")
arm = bpy.data.objects.new("Rig", ad)
bpy.context.scene.collection.objects.link(arm)
bpy.context.view_layer.objects.active = arm
bpy.ops.object.mode_set(mode='EDIT')
b1 = ad.edit_bones.new("Upper")
b1.head, b1.tail = (-3.5, 0, 0), (0, 0, 0)
b2 = ad.edit_bones.new("Lower")
b2.head, b2.tail = (0, 0, 0), (3.5, 0, 0)
b2.parent, b2.use_connect = b1, True
bpy.ops.object.mode_set(mode='OBJECT')
# Vertex groups (a linear ramp over the joint) so that Blender's Armature modifier, the reference
# below, deforms the same mesh with the same weights.
t = np.clip(V[:, 0] + 0.5, 0, 1)
for name, w in (("Upper", 1 - t), ("Lower", t)):
    g = obj.vertex_groups.new(name=name)
    g.add(np.nonzero(w == 1)[0].tolist(), 1.0, 'REPLACE')
    for i in np.nonzero((w > 0) & (w < 1))[0].tolist():
        g.add([i], float(w[i]), 'REPLACE')
mod = obj.modifiers.new("Armature", 'ARMATURE')
mod.object = arm
# The reference for the interleaved whole-frame blocks below: a copy of the mesh (vertex groups
# included) deformed by Blender's own Armature modifier (linear blend), disabled in viewports
# (out of the depsgraph) except during its own blocks.
ref_obj = obj.copy()
ref_obj.data = me.copy()
ref_obj.name = "Reference"
bpy.context.scene.collection.objects.link(ref_obj)
ref_obj.hide_viewport = True
for o in bpy.context.view_layer.objects:
    o.select_set(o in (obj, arm))
bpy.context.view_layer.objects.active = obj
t0 = time.perf_counter()
r = bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT', control_faces=5000)
tb = time.perf_counter() - t0
pb = arm.pose.bones["Lower"]
pb.rotation_mode = 'XYZ'
for fr, a in ((1, 0.0), (NFRAMES + 20, math.pi / 2)):
    pb.rotation_euler = (0, 0, a)
    pb.keyframe_insert("rotation_euler", frame=fr)
sc = bpy.context.scene
sc.frame_set(1)

# Instrument the handler's parts (module globals, looked up at call time).
parts = {"pose": [], "deform": [], "update": []}
parts_cpu = {k: [] for k in parts}


def _wrap(name, fn):
    def timed(*a, **k):
        c0, t0 = time.process_time(), time.perf_counter()
        res = fn(*a, **k)
        parts[name].append(time.perf_counter() - t0)
        parts_cpu[name].append(time.process_time() - c0)
        return res
    return timed


orig = {n: getattr(skeletal_live, n) for n in ("pose_matrices", "deformed", "update_object")}
skeletal_live.pose_matrices = _wrap("pose", orig["pose_matrices"])
skeletal_live.deformed = _wrap("deform", orig["deformed"])
skeletal_live.update_object = _wrap("update", orig["update_object"])


def play(first=2):
    """frame_set over NFRAMES consecutive keyframed frames: (wall ms per frame, CPU ms per frame)."""
    wall = []
    c0 = time.process_time()
    for fr in range(first, first + NFRAMES):
        t0 = time.perf_counter()
        sc.frame_set(fr)
        wall.append(time.perf_counter() - t0)
    cpu = (time.process_time() - c0) / NFRAMES
    sc.frame_set(1)
    return 1e3 * float(np.median(wall)), 1e3 * cpu


# Whole frames, A/B in interleaved blocks on the same bound object: this version's helper object
# against the previous version's target (the offset attribute on the mesh, Named Attribute node).
# Switching swaps the modifier's node group, the attribute and the stored target; the first frame
# after a switch (relations rebuilt, buffers) is not timed.
info = obj[skeletal_store.PROP]
ng_helper = obj.modifiers["dg_skeletal"].node_group
ng_attr = skeletal_live.offset_node_group()
ng_attr.use_fake_user = True


def use_target(target):
    if target == "ATTRIBUTE":
        obj.data.attributes.new(skeletal_store.ATTR, 'FLOAT_VECTOR', 'POINT')
        obj.modifiers["dg_skeletal"].node_group = ng_attr
    else:
        obj.data.attributes.remove(obj.data.attributes[skeletal_store.ATTR])
        obj.modifiers["dg_skeletal"].node_group = ng_helper
    info["target"] = target
    skeletal_live._buffers.clear()
    skeletal_live._last_pose.clear()
    sc.frame_set(NFRAMES + 20)  # untimed: the switch's one-off costs
    sc.frame_set(1)


blocks = {"HELPER": ([], []), "ATTRIBUTE": ([], [])}
for rep in range(3):
    for target in ("ATTRIBUTE", "HELPER"):
        use_target(target)
        w, c = play()
        blocks[target][0].append(w)
        blocks[target][1].append(c)


def show(bound):
    """Blocks of our bound mesh (bound=True) or of the reference copy with Blender's Armature
    modifier; the other object is out of the depsgraph and, for the reference, our handlers are off.
    The first frames after a switch (relations rebuilt) are not timed."""
    obj.hide_viewport, ref_obj.hide_viewport = not bound, bound
    set_handlers(skeletal_live.HANDLERS, add=bound)
    skeletal_live._last_pose.clear()
    lens = {k: len(v) for k, v in parts.items()}
    sc.frame_set(NFRAMES + 20)
    sc.frame_set(1)
    for k, v in parts.items():  # the handler's parts are timed in the blocks only
        del v[lens[k]:]
        del parts_cpu[k][lens[k]:]


# Whole frames: ours and Blender's Armature modifier (linear blend) on the same mesh, vertex groups and
# frames, in interleaved blocks, so that both see the same state of a shared host.
for k in parts:
    parts[k].clear()
    parts_cpu[k].clear()
n_blocks = 5
frames = {True: ([], []), False: ([], [])}
n_updates = n_deform = 0
for rep in range(n_blocks):
    for bound in (True, False):
        show(bound)
        n0, d0 = len(parts["update"]), len(parts["deform"])
        w, c = play()
        if bound:  # per block: the handler's calls and deforms in the timed frames (play() ends at frame 1)
            n_updates += len(parts["update"]) - n0 - 1
            n_deform += len(parts["deform"]) - d0 - 1
        frames[bound][0].append(w)
        frames[bound][1].append(c)
show(True)
frame_ms, frame_cpu_ms = float(np.median(frames[True][0])), float(np.median(frames[True][1]))
med = {k: 1e3 * float(np.median(v)) for k, v in parts.items()}
med_cpu = {k: 1e3 * float(np.median(v)) for k, v in parts_cpu.items()}
for k, fn in orig.items():
    setattr(skeletal_live, k, fn)
# OpenMP inside Blender: the same native deform with 1 thread and with all, interleaved (wall and
# process CPU per call; CPU above wall x threads used is spin-waiting).
names = list(info["bones"])
pose_b = skeletal_live.pose_matrices(obj, arm, names)
nthreads = dgmesh.num_threads()
omp = {1: ([], []), nthreads: ([], [])}
for _ in range(5):
    for t in omp:
        dgmesh.set_num_threads(t)
        c0, t0 = time.process_time(), time.perf_counter()
        skeletal_live.deformed(obj, pose_b)
        omp[t][0].append(time.perf_counter() - t0)
        omp[t][1].append(time.process_time() - c0)
dgmesh.set_num_threads(nthreads)

# Blender's own per-frame work on the bound mesh, without our handler: ~0 unless something still ties
# the mesh to the pose (a disabled Armature modifier with its object set did: one more evaluation).
set_handlers(skeletal_live.HANDLERS, add=False)
idle_ms, idle_cpu_ms = play()
set_handlers(skeletal_live.HANDLERS)

# The write alone: the helper's vertices (this version), the attribute (the previous one), a shape
# key (the first one).
n = len(V)
off = np.zeros(3 * n, dtype=np.float32)
helper = skeletal_store.helper_of(obj, info)
hverts = helper.data.vertices
w_helper = []
for _ in range(7):
    t0 = time.perf_counter()
    hverts.foreach_set("co", off)
    w_helper.append(time.perf_counter() - t0)

# Blender's evaluation of the mesh after a write (our modifier on top of the mesh), the part of
# frame_set outside our handler.
ev = []
c0 = time.process_time()
for _ in range(7):
    hverts.foreach_set("co", off)
    helper.data.update()
    t0 = time.perf_counter()
    bpy.context.view_layer.update()
    ev.append(time.perf_counter() - t0)
ev_cpu = (time.process_time() - c0) / 7

# Interleaved A/B of write + evaluation, wall and CPU: the helper (this version, on the bound
# object) against the offset attribute + Named Attribute modifier (previous version) and a shape key
# (first version), each on a copy of the mesh (vertex groups included) in the same scene.
obj2 = bpy.data.objects.new("A", me.copy())
bpy.context.scene.collection.objects.link(obj2)
att = obj2.data.attributes.new(skeletal_store.ATTR, 'FLOAT_VECTOR', 'POINT')
obj2.modifiers.new("dg_skeletal", 'NODES').node_group = ng_attr
obj3 = bpy.data.objects.new("K", me.copy())
bpy.context.scene.collection.objects.link(obj3)
obj3.shape_key_add(name="Basis")
kb2 = obj3.shape_key_add(name="K")
kb2.value = 1.0
co2 = np.empty(3 * n, dtype=np.float32)
me.vertices.foreach_get("co", co2)
bpy.context.view_layer.update()
w_attr = []
for _ in range(7):
    t0 = time.perf_counter()
    att.data.foreach_set("vector", off)
    w_attr.append(time.perf_counter() - t0)
ab = {"helper": ([], []), "attribute": ([], []), "shape_key": ([], [])}
for i in range(8):
    off[:] = 0.001 * (i + 1)
    for key in ab:
        c0, t0 = time.process_time(), time.perf_counter()
        if key == "helper":
            hverts.foreach_set("co", off)
            helper.data.update()
        elif key == "attribute":
            att.data.foreach_set("vector", off)
            obj2.data.update()
        else:
            kb2.data.foreach_set("co", co2 + off)
            obj3.data.update()
        bpy.context.view_layer.update()
        ab[key][0].append(time.perf_counter() - t0)
        ab[key][1].append(time.process_time() - c0)
bpy.data.objects.remove(obj2)
bpy.data.objects.remove(obj3)


def eval_after_write(k=7):
    w, c0 = [], time.process_time()
    for i in range(k):
        off[:] = 0.001 * i
        hverts.foreach_set("co", off)
        helper.data.update()
        t0 = time.perf_counter()
        bpy.context.view_layer.update()
        w.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(w)), 1e3 * (time.process_time() - c0) / k


# Shading options that change Blender's evaluation (the same for any deformer): smooth shading, and
# Auto Smooth (custom split normals; 3.x/4.0 only, gone in 4.1).
me.polygons.foreach_set("use_smooth", np.ones(len(F), dtype=bool))
smooth = eval_after_write()
autosmooth = None
if hasattr(me, "use_auto_smooth"):
    me.use_auto_smooth = True
    autosmooth = eval_after_write()
    me.use_auto_smooth = False
me.polygons.foreach_set("use_smooth", np.zeros(len(F), dtype=bool))

skeletal_live._buffers.clear()
skeletal_live._last_pose.clear()
# Reference: unbind (the Armature modifier comes back) and play the same frames with Blender's own
# linear blend skinning and Preserve Volume.
bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT')
ref = {}
for key, pv in (("lbs", False), ("dqs", True)):
    mod.use_deform_preserve_volume = pv
    ref[key] = play()
obj.shape_key_add(name="Basis")
kb = obj.shape_key_add(name="K")
co = np.empty(3 * n, dtype=np.float32)
obj.data.vertices.foreach_get("co", co)
w_key = []
for _ in range(5):
    t0 = time.perf_counter()
    kb.data.foreach_set("co", co)
    w_key.append(time.perf_counter() - t0)

out = {
    "V": n, "F": len(F), "blender": bpy.app.version_string, "bind_s": tb, "bind_result": sorted(r),
    "n_frames": NFRAMES, "n_deform": n_deform // n_blocks, "n_updates_per_block": n_updates // n_blocks, "n_updates": n_updates,
    "frame_ms": frame_ms, "frame_cpu_ms": frame_cpu_ms, "fps": 1e3 / frame_ms,
    "n_blocks": n_blocks, "frame_blocks": frames[True][0], "frame_blocks_cpu": frames[True][1],
    "reference_frame_blocks": frames[False][0], "reference_frame_blocks_cpu": frames[False][1],
    "reference_frame_ms": float(np.median(frames[False][0])),
    "reference_frame_cpu_ms": float(np.median(frames[False][1])),
    "no_handler_frame_ms": idle_ms, "no_handler_frame_cpu_ms": idle_cpu_ms,
    "pose_read_ms": med["pose"], "deform_ms": med["deform"], "handler_ms": med["update"],
    "write_ms": med["update"] - med["deform"] - med["pose"],
    "deform_cpu_ms": med_cpu["deform"], "handler_cpu_ms": med_cpu["update"],
    "ab_frame_helper_ms": float(np.median(blocks["HELPER"][0])),
    "ab_frame_helper_cpu_ms": float(np.median(blocks["HELPER"][1])),
    "ab_frame_attribute_ms": float(np.median(blocks["ATTRIBUTE"][0])),
    "ab_frame_attribute_cpu_ms": float(np.median(blocks["ATTRIBUTE"][1])),
    "ab_frame_blocks": {k: v[0] for k, v in blocks.items()},
    "ab_frame_blocks_cpu": {k: v[1] for k, v in blocks.items()},
    "threads": nthreads,
    "deform_1thread_ms": 1e3 * float(np.median(omp[1][0])), "deform_1thread_cpu_ms": 1e3 * float(np.median(omp[1][1])),
    "deform_nthreads_ms": 1e3 * float(np.median(omp[nthreads][0])),
    "deform_nthreads_cpu_ms": 1e3 * float(np.median(omp[nthreads][1])),
    "ab_helper_ms": 1e3 * float(np.median(ab["helper"][0])),
    "ab_helper_cpu_ms": 1e3 * float(np.median(ab["helper"][1])),
    "ab_attribute_ms": 1e3 * float(np.median(ab["attribute"][0])),
    "ab_attribute_cpu_ms": 1e3 * float(np.median(ab["attribute"][1])),
    "ab_shape_key_ms": 1e3 * float(np.median(ab["shape_key"][0])),
    "ab_shape_key_cpu_ms": 1e3 * float(np.median(ab["shape_key"][1])),
    "helper_write_ms": 1e3 * float(np.median(w_helper)),
    "attribute_write_ms": 1e3 * float(np.median(w_attr)), "shape_key_write_ms": 1e3 * float(np.median(w_key)),
    "eval_ms": 1e3 * float(np.median(ev)), "eval_cpu_ms": 1e3 * ev_cpu,
    "eval_smooth_ms": smooth[0], "eval_smooth_cpu_ms": smooth[1],
    "eval_autosmooth_ms": autosmooth[0] if autosmooth else None,
    "eval_autosmooth_cpu_ms": autosmooth[1] if autosmooth else None,
    "armature_lbs_frame_ms": ref["lbs"][0], "armature_lbs_frame_cpu_ms": ref["lbs"][1],
    "armature_dqs_frame_ms": ref["dqs"][0], "armature_dqs_frame_cpu_ms": ref["dqs"][1],
}
with open(os.environ["DGMESH_BENCH_OUT"], "w") as fh:
    json.dump(out, fh)
