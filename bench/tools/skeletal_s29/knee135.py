"""Why the armadillo's knee bent 135 degrees keeps a bone ratio under 0.9 through the layer with
Untangle Creases (issue 33, session 29): skeletal_joints' set-up (Blender's automatic weights); for
the whole mesh and the 5000-face control mesh, default and untangle_iterations=20, the crossing
pairs, the minimum ratio (posed / rest distance to the nearest bone segment, over the vertices
weighted to the shin, as the bench) and, for the vertices under 0.9, which bone is nearest and where
they lie along the posed shin (0 = knee, 1 = ankle). Then the same ratio with the shin's vertices
(all weight on it) moved rigidly with it: how far the pose alone drives them towards the other bones.

    /usr/bin/python3 bench/tools/skeletal_s29/knee135.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402
from bench.workloads.skeletal_limb import ARMADILLO_BONES, _seg_dist, armature_poses  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F = cgal_mesh("armadillo")
heads, tails = ARMADILLO_BONES
res = armature_poses(V, F, heads, tails, [(2, (-1, 0, 0), np.radians(135))])[0]
rest, W, pose = res["rest"], res["W"], res["pose0"]


def bone_d(X, P):
    out = []
    for j in range(len(rest)):
        A = P[j] @ np.linalg.inv(rest[j])
        out.append(_seg_dist(X, A[:3, :3] @ heads[j] + A[:3, 3], A[:3, :3] @ tails[j] + A[:3, 3]))
    return np.array(out)


b0 = bone_d(V, rest)
aff = (W[:, 2:].sum(1) > 0.01) & (b0.min(0) > 1e-9)
A = pose[2] @ np.linalg.inv(rest[2])
knee, ankle = A[:3, :3] @ heads[2] + A[:3, 3], A[:3, :3] @ tails[2] + A[:3, 3]
for path, cf in (("whole", len(F) + 1), ("layer", 5000)):
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=cf, bone_heads=heads, bone_tails=tails)
    for unt in (0, 20):
        X = rig.deform(pose, untangle_iterations=unt)
        bd = bone_d(X, pose)
        near = bd.min(0) / b0.min(0)
        low = aff & (near < 0.9)
        t = (X - knee) @ (ankle - knee) / ((ankle - knee) @ (ankle - knee))
        print(f"{path} untangle {unt:2d}: pairs {len(self_intersecting_pairs(X, F)):5d}, min ratio {near[aff].min():.3f}, "
              f"{low.sum()} vertices under 0.9, nearest bones {np.bincount(bd.argmin(0)[low], minlength=3)}, "
              f"along the shin {np.round(t[low].min(), 2) if low.any() else '-'} .. {np.round(t[low].max(), 2) if low.any() else '-'}")
rigid = W[:, 2] >= 0.999
Xr = V @ A[:3, :3].T + A[:3, 3]
near = bone_d(Xr, pose).min(0) / b0.min(0)
sel = aff & rigid
print(f"the shin's {sel.sum()} rigid vertices moved with it: min ratio {near[sel].min():.3f}, {(near[sel] < 0.9).sum()} under 0.9")
