"""Issue 33's crease pairs on the bench skeletal_limb legs, with and without the untangling
(untangle_iterations=20; --slide adds the joint contact, contact_slide=3):
Blender's automatic weights and Armature modifier (LBS, DQS) through bench/workloads/_skeletal_limb.py,
ours on the whole mesh and through the multiresolution layer (5000-face control mesh), bends of
45 / 90 / 135 degrees and a 180-degree twist of the lower bone; pairs over the whole mesh
(bench/tools/skeletal_crease_probe.py's counter) and the minimum ratio of the distance to the bones
over the vertices with weight on the moving bone.

    /usr/bin/python3 bench/tools/skeletal_crease_legs.py camel|armadillo [--slide]
"""
import sys, pathlib, time
ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import numpy as np  # noqa: E402
import dgmesh  # noqa: E402
from bench.common import cgal_mesh
from bench.workloads.skeletal_limb import CAMEL_BONES, ARMADILLO_BONES, armature_poses, bone_distance
from skeletal_crease_probe import self_intersecting_pairs
which = sys.argv[1]
model, mesh, (heads, tails), bend_axis = {"camel": ("camel leg", "camel", CAMEL_BONES, (1, 0, 0)),
                                          "armadillo": ("armadillo leg", "armadillo", ARMADILLO_BONES, (-1, 0, 0))}[which]
V, F = cgal_mesh(mesh)
axis = tails[2] - heads[2]
poses = {"bend 45": (2, bend_axis, np.pi / 4), "bend 90": (2, bend_axis, np.pi / 2), "bend 135": (2, bend_axis, 3 * np.pi / 4),
         "twist 180": (2, tuple(axis / np.linalg.norm(axis)), np.pi)}
res = armature_poses(V, F, heads, tails, poses)[0]
rest, W = res["rest"], res["W"]
t = time.time()
rig = dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=len(F) + 1)
rig_mr = dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=5000)
print(model, len(V), "bind s %.1f" % (time.time() - t), flush=True)
b0 = bone_distance(V, rest, rest, heads, tails)
aff = (W[:, 2] > 0.01) & (b0 > 1e-9)
print("rest pairs", len(self_intersecting_pairs(V, F)[0]))
for p, pname in enumerate(poses):
    pose = res[f"pose{p}"]
    out = {"LBS (Blender)": res[f"lbs{p}"], "DQS (Blender)": res[f"dqs{p}"],
           "ours": rig.deform(pose), "ours untangle 20": rig.deform(pose, untangle_iterations=20),
           "multires": rig_mr.deform(pose), "multires untangle 20": rig_mr.deform(pose, untangle_iterations=20)}
    if "--slide" in sys.argv:  # the joint contact's columns of bench/notes/skeletal.md
        out.update({"ours slide 3": rig.deform(pose, contact_slide=3),
                    "multires slide 3": rig_mr.deform(pose, contact_slide=3)})
    for k, X in out.items():
        r = (bone_distance(X, rest, pose, heads, tails) / np.maximum(b0, 1e-300))[aff]
        print(model, pname, "%-18s pairs %5d  min bone ratio %.3f" % (k, len(self_intersecting_pairs(X, F)[0]), r.min()), flush=True)
