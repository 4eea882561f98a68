"""Untangle Creases through the layer on bench skeletal_joints' meshes and poses (issue 33, session
28; what Untangle Creases Render's default rests on): crossing pairs over the whole mesh and the wall
ms of one deform (Python included) with 0 (the default) / 3 / 5 / 10 / 20 iterations.

    /usr/bin/python3 bench/tools/skeletal_s28/untangle_joints.py
"""
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402
from bench.workloads.skeletal_limb import ARMADILLO_BONES, CAMEL_BONES, JOINT_POSES, armature_poses  # noqa: E402
from dgmesh.skeletal import capsule, self_intersecting_pairs  # noqa: E402

CAPSULE_BONES = (np.array([[-3.5, 0, 0], [0, 0, 0.0]]), np.array([[0, 0, 0], [3.5, 0, 0.0]]))
cases = [("capsule", *capsule(0.5, 6.0, 64, 10, 128), CAPSULE_BONES, 1, (0, 0, 1)),
         ("camel leg", *cgal_mesh("camel"), CAMEL_BONES, 2, (1, 0, 0)),
         ("armadillo leg", *cgal_mesh("armadillo"), ARMADILLO_BONES, 2, (-1, 0, 0))]
for model, V, F, (heads, tails), bone, bend_axis in cases:
    axis = tuple((tails[bone] - heads[bone]) / np.linalg.norm(tails[bone] - heads[bone]))
    poses = [(bone, bend_axis if p.startswith("bend") else axis, np.radians(float(p.split()[1]))) for p in JOINT_POSES]
    res = armature_poses(V, F, heads, tails, poses)[0]
    rig = dgmesh.SkeletalRig.bind(V, F, res["rest"], res["W"], control_faces=5000, bone_heads=heads, bone_tails=tails)
    print(model, len(V), "vertices", flush=True)
    for p, name in enumerate(JOINT_POSES):
        cells = []
        for it in (0, 3, 5, 10, 20):
            t = time.perf_counter()
            X = rig.deform(res[f"pose{p}"], untangle_iterations=it)
            ms = 1e3 * (time.perf_counter() - t)
            cells.append("%d: %d (%.0f ms)" % (it, len(self_intersecting_pairs(X, F)), ms))
        print(" ", name, " | ".join(cells), flush=True)
