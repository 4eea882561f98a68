"""Session 30 (issue 33): where the one-sided thickness step leaves flesh farther from the union of medial
balls than at rest. skeletal_joints' capsule (Blender's automatic weights, cached by variants.py), through the
5000-face control mesh, bent 60 and 90 degrees: the vertices whose f - f_rest (eq. 6.13) exceeds 0.2 and 0.4
edge lengths, split by the side of the joint they lie on (inner: towards the concave corner, the sum of
the two limbs' directions from the joint).

    /usr/bin/python3 bench/tools/skeletal_s30/bulge.py
"""
import os
import pathlib
import pickle
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal_limb import _joint_cases  # noqa: E402
from dgmesh.skeletal import union_of_balls_distance  # noqa: E402

model, V, F, (heads, tails), bone, axis = _joint_cases(False)[0]
V, F = np.asarray(V, float), np.asarray(F)
res = pickle.loads((pathlib.Path(os.environ.get("CACHE", "/tmp/dgmesh_s30")) / "capsule.pkl").read_bytes())
rig = dgmesh.SkeletalRig.bind(V, F, res["rest"], res["W"], control_faces=5000, bone_heads=heads, bone_tails=tails)
e = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
r = np.asarray(rig.radii)
f_rest = union_of_balls_distance(V, rig.skeleton_vertices, r)
for deg in (60, 90):
    pose = res[f"pose{deg - 30}"]  # variants.py's bend sweep starts at 30 degrees, one per frame
    X = rig.deform(pose)
    g = (union_of_balls_distance(X, rig.skeleton_pose(pose), r) - f_rest) / e
    a = np.radians(deg)
    corner = np.array([-1 + np.cos(a), np.sin(a), 0.0])  # limb 1 along -x, limb 2 turned about z by a
    for lo in (0.2, 0.4):
        m = g > lo
        inner = (X[m] - heads[bone]) @ corner > 0
        print(f"bend {deg}: {m.sum()} vertices over {lo} e, inner {inner.sum()}, outer {(~inner).sum()}; max {g.max():.2f} e")
