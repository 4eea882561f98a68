"""Where the crease pairs come from (issue 33, session 28): on the capsule of
bench/tools/skeletal_crease_probe.py (probe_rigs, probe_poses), DQS against the bare reconstruction
(eq. 6.11, fairing_steps=0: no thickness steps) and the default, whole mesh and through the 5000-face
control mesh. Per pose: self-intersecting pairs over the whole mesh, minimum bone ratio, sum
(f - f_rest)^2 of eq. 6.13 against the whole rig's posed skeleton.

    cd bench/tools && /usr/bin/python3 skeletal_s28/bare.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from dgmesh.skeletal import capsule, self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402
from skeletal_crease_probe import REST, bone_ratio_min, probe_poses, probe_rigs  # noqa: E402

V, F = capsule(0.5, 6.0, 64, 10, 128)
rigs = probe_rigs(V, F)
S0, radii = rigs["whole"].skeleton_vertices, rigs["whole"].radii
f0 = dgmesh.union_of_balls_distance(V, S0, radii)
for path, rig in rigs.items():
    for name, R in probe_poses().items():
        pose = np.array([REST[0], R @ REST[1]])
        Sd = rigs["whole"].skeleton_pose(pose)
        cells = []
        for label, X in (("DQS", skeletal_subspace_deform(V, rigs["whole"].weights, REST, pose, dual_quaternion=True)),
                         ("bare", rig.deform(pose, fairing_steps=0)), ("default", rig.deform(pose))):
            thick = ((dgmesh.union_of_balls_distance(X, Sd, radii) - f0) ** 2).sum()
            cells.append("%s %d (%.3f, %.3g)" % (label, len(self_intersecting_pairs(X, F)), bone_ratio_min(X, V, pose), thick))
        print(path, name, " | ".join(cells), flush=True)
