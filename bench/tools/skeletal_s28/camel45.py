"""Which faces cross in the camel's knee bent 45 degrees (issue 33, session 28; bench
skeletal_joints' camel leg, Blender's automatic weights): the pairs of ours on the whole mesh,
through the 5000-face control mesh and of Blender's Preserve Volume, whether they also cross at
rest, and the first pairs' face centres and weights on the shin bone.

    /usr/bin/python3 bench/tools/skeletal_s28/camel45.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402
from bench.workloads.skeletal_limb import CAMEL_BONES, armature_poses  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F = cgal_mesh("camel")
heads, tails = CAMEL_BONES
res = armature_poses(V, F, heads, tails, [(2, (1, 0, 0), np.pi / 4)])[0]
rest, W, pose = res["rest"], res["W"], res["pose0"]
bind = dict(bone_heads=heads, bone_tails=tails)
whole = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=len(F) + 1, **bind)
lay = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000, **bind)
P0 = set(map(tuple, self_intersecting_pairs(V, F)))
C = V[F].mean(1)
for name, X in (("whole", whole.deform(pose)), ("multires", lay.deform(pose)), ("dqs", res["dqs0"])):
    P = self_intersecting_pairs(X, F)
    print(name, len(P), "of which at rest too:", sum(tuple(p) in P0 for p in P))
    for a, b in P[:8]:
        print("   faces", a, b, "centres", np.round(C[a], 3), np.round(C[b], 3), "shin weight %.2f %.2f" % (W[F[a], 2].mean(), W[F[b], 2].mean()))
