"""Session 36 (issue 33): a joint bent and twisted at once. The joint fillet turns each cross-section
of its band by the vertex's share of the child's twist; these poses' twist does not dominate the
swing (except 90+90 and 45+90), so ring_twist's blend does not act on them. Crossing pairs of ours
with the defaults, of ours with ring_twist=False (the fillet's share from the weights: the default
before session 36 on the poses whose twist does not dominate; on 90+90 and 45+90 it also drops the
ring blend the default had),
and of dual quaternion skinning with the same weights (`skeletal_subspace_deform(...,
dual_quaternion=True)`, what Blender's Preserve Volume computes), and our minimum bone ratio.

- bench skeletal_speed's 178K capsule bound without weights (the rig's Gaussian weights of its skeletal
  points, through the 5000-face control mesh), the second bone bent about z and twisted about its own
  axis; DQS with the same recipe's weights of the dense vertices;
- skeletal_joints' capsule and legs with Blender's automatic weights (cached by
  bench/tools/skeletal_s30/variants.py in $CACHE, default /tmp/dgmesh_s30: run it once first), the
  moving bone's Blender bend pose followed by a twist about its rest axis, whole mesh and through the
  layer.

    /usr/bin/python3 bench/tools/skeletal_s36/bend_twist.py [speed|joints]...
"""
import os
import pathlib
import pickle
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import _rot, speed_capsule  # noqa: E402
from bench.workloads.skeletal_limb import _joint_cases, bone_distance, min_bone_ratio, moving_vertices  # noqa: E402
from dgmesh.skeletal import gaussian_bone_weights, self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402

COMBOS = [(60, 45), (60, -45), (90, 45), (90, -45), (90, 90), (45, 90)]


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


def speed():
    V, F, rest, heads, tails = speed_capsule(2)
    rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
    # DQS with the rig's recipe applied to the dense vertices (Gaussian weights of the distance to the
    # bones, sigma a fifth of the median medial radius; the rig weights its skeletal points so).
    W = gaussian_bone_weights(V, heads, tails, 0.2 * float(np.median(rig.radii)))
    poses = [np.array([rest[0], _rot((0, 0, 1), np.radians(b)) @ _rot((1, 0, 0), np.radians(t)) @ rest[1]])
             for b, t in COMBOS]
    b0 = bone_distance(V, rest, rest, heads, tails)
    ok = b0 > 1e-9
    row("178K capsule, layer", rig, V, F, W, rest, poses,
        lambda X, pose: float((bone_distance(X, rest, pose, heads, tails)[ok] / b0[ok]).min()))


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
    for part in sys.argv[1:] or ["speed", "joints"]:
        {"speed": speed, "joints": joints}[part]()
