"""Issue 33, session 25: follow_twist on bench/tools/skeletal_untangle_probe.py's capsule (r 0.5, length 6,
64 x 10 x 128, the rig's Gaussian weights; DQS = skeletal_subspace_deform with the same weights), whole
mesh and 5000-face control mesh, default and untangle_iterations=20, without / with follow_twist:
self-intersecting pairs (native count) and min ratio of the distance to the bones over all vertices.

    /usr/bin/python3 bench/tools/skeletal_twist_capsule.py
"""
import sys
from pathlib import Path

import numpy as np

sys.path[:0] = [str(Path(__file__).resolve().parents[2] / "addon"), str(Path(__file__).resolve().parent)]
from dgmesh.skeletal import capsule, skeletal_subspace_deform, self_intersecting_pairs  # noqa: E402
from skeletal_crease_probe import REST, bone_ratio_min, probe_poses, probe_rigs  # noqa: E402

V, F = capsule(0.5, 6.0, 64, 10, 128)
rigs = probe_rigs(V, F)
for name, R in probe_poses().items():
    pose = np.array([REST[0], R @ REST[1]])
    X = skeletal_subspace_deform(V, rigs["whole"].weights, REST, pose, dual_quaternion=True)
    print("%-9s DQS %5d (%.3f)" % (name, len(self_intersecting_pairs(X, F)), bone_ratio_min(X, V, pose)), flush=True)
    for path, rig in rigs.items():
        for unt in (0, 20):
            cells = []
            for ft in (False, True):
                X = rig.deform(pose, untangle_iterations=unt, follow_twist=ft)
                cells.append("%5d (%.3f)" % (len(self_intersecting_pairs(X, F)), bone_ratio_min(X, V, pose)))
            print("   %-8s untangle %2d  without / with follow_twist: %s / %s" % (path, unt, *cells), flush=True)
