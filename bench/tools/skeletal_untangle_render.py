"""Close-up renders of issue 33's crease: the 64 x 10 x 128 capsule bent 90 degrees (Gaussian
weights), LBS, DQS, ours (default) and ours with the untangling (untangle_iterations=20), the faces
within 1.6 of the joint, the faces of self-intersecting pairs in red. Into
bench/images/skeletal_untangle_capsule_bend_90.png (Blender, Cycles CPU).

    /usr/bin/python3 bench/tools/skeletal_untangle_render.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import _render  # noqa: E402
from dgmesh.skeletal import capsule, self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402
from skeletal_crease_probe import HEADS, REST, TAILS, rot  # noqa: E402

V, F = capsule(0.5, 6.0, 64, 10, 128)
rig = dgmesh.SkeletalRig.bind(V, F, REST, None, bone_heads=HEADS, bone_tails=TAILS, control_faces=len(F) + 1)
pose = np.array([REST[0], rot((0, 0, 1), np.radians(90)) @ REST[1]])
near = np.linalg.norm(V[F].mean(1), axis=1) < 1.6
Fn = F[near]
used = np.unique(Fn)
remap = -np.ones(len(V), int)
remap[used] = np.arange(len(used))
panels = []
for X in (skeletal_subspace_deform(V, rig.weights, REST, pose), skeletal_subspace_deform(V, rig.weights, REST, pose, dual_quaternion=True),
          rig.deform(pose), rig.deform(pose, untangle_iterations=20)):
    hit = np.zeros(len(F), bool)
    P = self_intersecting_pairs(X, F)
    hit[P.ravel()] = True
    print(len(P), "pairs")
    C = np.where(hit[near][:, None], np.array([0.9, 0.05, 0.05]), np.array([0.7, 0.7, 0.68]))
    panels.append((X[used], remap[Fn], C))
print(_render("skeletal_untangle_capsule_bend_90.png", panels, up="Z", size=(1200, 320), samples=16, view=(-1.0, 1.0, 0.35), gap=0.6))
