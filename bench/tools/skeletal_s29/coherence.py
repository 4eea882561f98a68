"""Is Untangle Creases smooth over an animation? (issue 33, session 29). A bend swept one degree per
frame through bench skeletal_joints' set-up (Blender's automatic weights, through the 5000-face
control mesh): per frame, the crossing pairs with the defaults and with untangle_iterations=10
(Untangle Creases Render's default at the time), the untangling's correction (untangled minus
default, in mean edge lengths e) and how much that correction changes from the previous frame
(largest vertex, and how many vertices change by more than one edge length). For comparison the fold guard's own correction (default
minus fold_guard=0) and its change. The limb's rigid motion moves its tip about 1.2 e per degree on
the capsule.

    /usr/bin/python3 bench/tools/skeletal_s29/coherence.py capsule 60 100
    /usr/bin/python3 bench/tools/skeletal_s29/coherence.py armadillo 70 100
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal_limb import _joint_cases, armature_poses  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

def rotation(axis, angle, pivot):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    M = np.eye(4)
    M[:3, :3] = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    M[:3, 3] = pivot - M[:3, :3] @ pivot
    return M


def main(model, first, last):
    # skeletal_joints' meshes ("capsule", "camel leg", "armadillo leg"), chosen by their first word.
    _, V, F, (heads, tails), bone, axis = next(c for c in _joint_cases(False) if c[0].split()[0] == model)
    V, F = np.asarray(V, float), np.asarray(F)
    res = armature_poses(V, F, heads, tails, [(bone, axis, 0.0)])[0]
    rest, W = res["rest"], res["W"]
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000, bone_heads=heads, bone_tails=tails)
    e = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
    prev = None
    worst = {"untangle": 0.0, "guard": 0.0}
    for deg in range(first, last + 1):
        M = rotation(axis, np.radians(deg), heads[bone])
        pose = np.array([M @ rest[j] if j >= bone else rest[j] for j in range(len(rest))])
        X = rig.deform(pose)
        corr = {"untangle": rig.deform(pose, untangle_iterations=10) - X, "guard": X - rig.deform(pose, fold_guard=0)}
        cells = [f"{deg:4d} pairs {len(self_intersecting_pairs(X, F)):4d} / untangled "
                 f"{len(self_intersecting_pairs(X + corr['untangle'], F)):4d}"]
        for k, c in corr.items():
            cell = f"{k} correction {np.linalg.norm(c, axis=1).max() / e:5.2f} e"
            if prev is not None:
                jump = np.linalg.norm(c - prev[k], axis=1) / e
                worst[k] = max(worst[k], jump.max())
                cell += f", change {jump.max():5.2f} e ({(jump > 1).sum():4d} vertices over 1 e)"
            cells.append(cell)
        prev = corr
        print(" | ".join(cells), flush=True)
    print(f"largest change from one degree to the next: untangling {worst['untangle']:.2f} e, "
          f"fold guard {worst['guard']:.2f} e (mean edge {e:.4g})")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]))
