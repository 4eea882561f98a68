"""Blender's own unwraps of triangle meshes, for bench workload unwrap_vs_blender.

Runs inside any Blender (3.4 on bookworm, 4.3 in the trixie lane root) without the add-on:

    blender --background --factory-startup --python bench/tools/blender_uv_peer.py -- \
        OUTDIR METHOD[,METHOD...] MESH.off [MESH.off ...]

METHOD: ANGLE_BASED, CONFORMAL, MINIMUM_STRETCH (Blender 4.3+: SLIM, its defaults),
ABF_MINIMIZE_STRETCH_<N> (ANGLE_BASED, then UV > Minimize Stretch with N iterations) or
SMART_PROJECT (Smart UV Project, its defaults: angle limit 66 degrees, island margin 0, packed) or
SMART_SEAMS_MINIMUM_STRETCH (Blender 4.3+: Smart UV Project, UV > Seams from Islands, then Unwrap with
MINIMUM_STRETCH on those seams, packed; the time is that of all three). Every mesh
is unwrapped whole (all faces selected, margin 0) in a fresh scene; the time is the wall time of
the operators alone. Writes OUTDIR/<stem>__<METHOD>.npy (the corner UVs, (m, 3, 2) float64: corner
k of triangle f) and OUTDIR/result.json ({"blender": version, "runs": {stem: {METHOD: seconds}}});
the caller measures the UVs (dgmesh.uv_metrics on the triangle soup).
"""

import json
import os
import sys
import time

import bpy
import numpy as np


def read_off(path):
    words = []
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].split()
            words.extend(line)
    assert words[0].endswith("OFF"), path
    nv, nf = int(words[1]), int(words[2])
    V = np.array(words[4:4 + 3 * nv], dtype=np.float64).reshape(nv, 3)
    rest = words[4 + 3 * nv:]
    F, k = [], 0
    for _ in range(nf):
        n = int(rest[k])
        if n != 3:
            raise SystemExit(f"{path}: only triangle meshes (a face has {n} corners)")
        F.append([int(x) for x in rest[k + 1:k + 4]])
        k += 1 + n
    return V, np.array(F, dtype=np.int32)


def add_object(name, V, F):
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", V.astype(np.float32).ravel())
    mesh.loops.add(3 * len(F))
    mesh.loops.foreach_set("vertex_index", F.ravel())
    mesh.polygons.add(len(F))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(F), 3, np.int32))
    mesh.update(calc_edges=True)
    mesh.validate()
    if len(mesh.polygons) != len(F):
        raise SystemExit(f"{name}: Blender dropped faces when validating ({len(mesh.polygons)} of {len(F)})")
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    mesh.uv_layers.new(name="UVMap")
    return obj


def unwrap(obj, method):
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.select_all(action="SELECT")
    t0 = time.perf_counter()
    if method == "SMART_PROJECT":
        bpy.ops.uv.smart_project()
    elif method == "SMART_SEAMS_MINIMUM_STRETCH":
        bpy.ops.uv.smart_project()
        bpy.ops.uv.select_all(action="SELECT")
        bpy.ops.uv.seams_from_islands(mark_seams=True)
        bpy.ops.uv.unwrap(method="MINIMUM_STRETCH", margin=0.0)
    elif method.startswith("ABF_MINIMIZE_STRETCH_"):
        bpy.ops.uv.unwrap(method="ANGLE_BASED", margin=0.0)
        bpy.ops.uv.minimize_stretch(iterations=int(method.rsplit("_", 1)[1]))
    else:
        bpy.ops.uv.unwrap(method=method, margin=0.0)
    t = time.perf_counter() - t0
    bpy.ops.object.mode_set(mode="OBJECT")
    return t


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    out, methods, meshes = args[0], args[1].split(","), args[2:]
    os.makedirs(out, exist_ok=True)
    res = {"blender": bpy.app.version_string, "runs": {}}
    for path in meshes:
        stem = os.path.splitext(os.path.basename(path))[0]
        V, F = read_off(path)
        res["runs"][stem] = {}
        for method in methods:
            bpy.ops.wm.read_factory_settings(use_empty=True)
            obj = add_object(stem, V, F)
            t = unwrap(obj, method)
            mesh = obj.data
            # The polygons are the input triangles in order, their loops 3f, 3f + 1, 3f + 2.
            lv = np.empty(len(mesh.loops), np.int32)
            mesh.loops.foreach_get("vertex_index", lv)
            if not np.array_equal(lv, F.ravel()):
                raise SystemExit(f"{stem}: Blender reordered the loops")
            uv = np.empty(2 * len(mesh.loops), np.float32)
            mesh.uv_layers.active.data.foreach_get("uv", uv)
            np.save(os.path.join(out, f"{stem}__{method}.npy"), uv.astype(np.float64).reshape(-1, 3, 2))
            res["runs"][stem][method] = t
            print(f"blender_uv_peer: {stem} {method} {t:.3f} s", flush=True)
    with open(os.path.join(out, "result.json"), "w") as f:
        json.dump(res, f, indent=1)


if __name__ == "__main__":  # Blender runs --python scripts as __main__; auto_unwrap_render imports add_object
    main()
