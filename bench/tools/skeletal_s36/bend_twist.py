"""Session 36 (issue 33): a joint bent and twisted at once. The joint fillet turns each cross-section
of its band by the vertex's share of the child's twist; these poses' twist does not dominate the
swing (except 90+90 and 45+90), so ring_twist's blend does not act on them. Crossing pairs of ours
with the defaults, of ours with ring_twist=False (the fillet's share from the weights: the default
before session 36 on the poses whose twist does not dominate; on 90+90 and 45+90 it also drops the
ring blend the default had), and of dual quaternion skinning with the same weights (`skeletal_subspace_deform(...,
dual_quaternion=True)`, what Blender's Preserve Volume computes), and our minimum bone ratio.

skeletal_joints' capsule and legs with Blender's automatic weights (cached by
bench/tools/skeletal_s30/variants.py in $CACHE, default /tmp/dgmesh_s30: run it once first), the
moving bone's Blender bend pose followed by a twist about its rest axis, whole mesh and through the
layer. (The same poses on skeletal_speed's 178K capsule: bench skeletal_bend_twist.)

    /usr/bin/python3 bench/tools/skeletal_s36/bend_twist.py
"""
import os
import pathlib
import pickle
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import BEND_TWIST as COMBOS, _rot  # noqa: E402
from bench.workloads.skeletal_limb import _joint_cases, bone_distance, min_bone_ratio, moving_vertices  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402


def turn_about(axis, angle, point):
    """4 x 4 rotation by `angle` about the line through `point` along `axis`."""
    M = _rot(axis, angle)
    M[:3, 3] = point - M[:3, :3] @ point
    return M


def row(label, rig, V, F, W, rest, poses, ratio):
    cells = []
    for (b, t), pose in zip(COMBOS, poses):
        X = rig.deform(pose)
        ours = len(self_intersecting_pairs(X, F))
        by_weights = len(self_intersecting_pairs(rig.deform(pose, ring_twist=False), F))
        dqs = len(self_intersecting_pairs(skeletal_subspace_deform(V, W, rest, pose, dual_quaternion=True), F))
        cells.append(f"{b}+{t}: {ours} / {by_weights} / {dqs} ({ratio(X, pose):.3f})")
    print(f"{label:22s} " + " | ".join(cells), flush=True)


def joints():
    cache = pathlib.Path(os.environ.get("CACHE", "/tmp/dgmesh_s30"))
    for model, V, F, (heads, tails), bone, _ in _joint_cases(False):
        name = model.split()[0]
        V, F = np.asarray(V, float), np.asarray(F)
        res = pickle.loads((cache / f"{name}.pkl").read_bytes())
        rest, W = res["rest"], res["W"]
        poses = []
        for b, t in COMBOS:
            pose = res[f"pose{b - 30}"].copy()  # variants.py's bend sweep starts at 30 degrees
            A = pose[bone] @ np.linalg.inv(rest[bone])
            pose[bone] = A @ turn_about(tails[bone] - heads[bone], np.radians(t), heads[bone]) @ rest[bone]
            poses.append(pose)
        b0 = bone_distance(V, rest, rest, heads, tails)
        moving = moving_vertices(W, bone, b0)
        for path in ("whole", "layer"):
            faces = min(5000, len(F) // 2) if path == "layer" else len(F) + 1
            rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=faces, bone_heads=heads, bone_tails=tails)
            row(f"{name} {path}", rig, V, F, W, rest, poses,
                lambda X, pose: min_bone_ratio(X, rest, pose, heads, tails, b0, moving))


if __name__ == "__main__":
    print("cells: bend+twist degrees: ours / ours with ring_twist=False / DQS crossing pairs (our min bone ratio)")
    joints()
