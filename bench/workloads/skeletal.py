"""Skeletal deformation workloads (thesis chapter 6): thickness quality against linear blend
skinning and dual-quaternion skinning on a capsule, and bind / per-pose speed.

    /usr/bin/python3 bench/run.py skeletal_quality skeletal_speed

LBS and DQS are computed here in numpy with the same weights (the formulas of Blender's Armature
modifier without / with Preserve Volume); the comparison inside Blender itself is not run yet.
"""

import time

import numpy as np

import dgmesh
from bench.common import loop_subdivide, median_time, table
from dgmesh.skeletal import capsule, gaussian_bone_weights, skeletal_subspace_deform


def _bone(head):
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (0, -1, 0), (1, 0, 0), (0, 0, 1), head
    return m


def _rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    return m


def _quat(R):
    w = np.sqrt(max(0.0, 1 + np.trace(R))) / 2
    if w > 1e-6:
        return np.array([w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)])
    i = np.argmax(np.diag(R))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = np.sqrt(max(0.0, 1 + R[i, i] - R[j, j] - R[k, k])) * 2
    q = np.zeros(4)
    q[i + 1] = s / 4
    q[0] = (R[k, j] - R[j, k]) / s
    q[j + 1] = (R[j, i] + R[i, j]) / s
    q[k + 1] = (R[k, i] + R[i, k]) / s
    return q


def _qmul(a, b):
    w1, v1, w2, v2 = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([w1 * w2 - np.sum(v1 * v2, -1, keepdims=True), w1 * v2 + w2 * v1 + np.cross(v1, v2)], -1)


def dqs(P, W, rest, pose):
    """Dual-quaternion skinning (Kavan et al.; Blender's Preserve Volume)."""
    B = len(rest)
    q0, qe = np.zeros((B, 4)), np.zeros((B, 4))
    for j in range(B):
        A = pose[j] @ np.linalg.inv(rest[j])
        q0[j] = _quat(A[:3, :3])
        qe[j] = 0.5 * _qmul(np.r_[0, A[:3, 3]], q0[j])
    sign = np.where(q0 @ q0[np.argmax(W, 1)].T < 0, -1, 1)  # unused for 2 bones beyond alignment
    ref = q0[np.argmax(W, 1)]
    s = np.sign(np.einsum("bk,nk->nb", q0, ref))
    s[s == 0] = 1
    Q0 = np.einsum("nb,nb,bk->nk", W, s, q0)
    Qe = np.einsum("nb,nb,bk->nk", W, s, qe)
    n = np.linalg.norm(Q0, axis=1, keepdims=True)
    Q0, Qe = Q0 / n, Qe / n
    w, v = Q0[:, :1], Q0[:, 1:]
    rot = P + 2 * np.cross(v, np.cross(v, P) + w * P)
    t = 2 * (Q0[:, :1] * Qe[:, 1:] - Qe[:, :1] * Q0[:, 1:] + np.cross(Q0[:, 1:], Qe[:, 1:]))
    del sign
    return rot + t


def _seg(P, a, b):
    ab = b - a
    t = np.clip((P - a) @ ab / (ab @ ab), 0, 1)
    return np.linalg.norm(a + t[:, None] * ab - P, axis=1)


def _bone_dist(X, rest, pose, heads, tails):
    d = []
    for j in range(len(rest)):
        A = pose[j] @ np.linalg.inv(rest[j])
        d.append(_seg(X, A[:3, :3] @ heads[j] + A[:3, 3], A[:3, :3] @ tails[j] + A[:3, 3]))
    return np.min(d, 0)


def _volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def quality(quick):
    V, F = capsule(0.5, 6.0, 48 if not quick else 32, 8, 96 if not quick else 48)
    rest = np.array([_bone((-3.5, 0, 0)), _bone((0, 0, 0))])
    heads = np.array([[-3.5, 0, 0], [0, 0, 0.0]])
    tails = np.array([[0, 0, 0], [3.5, 0, 0.0]])
    weight_sets = {
        "gaussian (sigma 0.1)": gaussian_bone_weights(V, heads, tails, 0.1),
        "linear ramp over [-0.5, 0.5]": np.c_[1 - np.clip(V[:, 0] + 0.5, 0, 1), np.clip(V[:, 0] + 0.5, 0, 1)],
    }
    poses = {"bend 90": np.array([rest[0], _rot((0, 0, 1), np.pi / 2) @ rest[1]]),
             "twist 180": np.array([rest[0], _rot((1, 0, 0), np.pi) @ rest[1]])}
    b0 = _bone_dist(V, rest, rest, heads, tails)
    ok = b0 > 1e-9
    vol0 = _volume(V, F)
    rows, data = [], {}
    for wname, W in weight_sets.items():
        rig = dgmesh.SkeletalRig.bind(V, F, rest, W)
        for pname, pose in poses.items():
            _, Sd = rig.deform_control(pose)
            results = {
                "LBS": skeletal_subspace_deform(V, W, rest, pose),
                "DQS": dqs(V, W, rest, pose),
                "ours, 2 fairing steps": rig.deform(pose, fairing_steps=2),
                "ours, 4 fairing steps": rig.deform(pose, fairing_steps=4),
                "ours, no fairing": rig.deform(pose, fairing_steps=0),
                "basic (6.3)": rig.deform(pose, method="basic"),
            }
            for mname, X in results.items():
                f = dgmesh.union_of_balls_distance(X, Sd, rig.radii)
                r = _bone_dist(X, rest, pose, heads, tails)[ok] / b0[ok]
                row = [wname, pname, mname, float((f**2).sum()), float(r.min()), float(r.mean()),
                       float(_volume(X, F) / vol0)]
                rows.append(row)
                data[f"{wname}|{pname}|{mname}"] = dict(zip(["sum_f2", "min_ratio", "mean_ratio", "volume_ratio"],
                                                            row[3:]))
    md = ["### Skeletal deformation quality (capsule r 0.5, length 6, %d vertices, 2 bones)" % len(V), "",
          "Thickness error sum f^2 of eq. 6.13 against the SSD-deformed skeletal mesh; ratio of each vertex's "
          "distance to the bone segments after / before; volume ratio. LBS and DQS are numpy re-implementations "
          "with the same weights (not Blender's modifier run).", "",
          table(["weights", "pose", "method", "sum f^2", "min ratio", "mean ratio", "volume"], rows), "",
          "`/usr/bin/python3 bench/run.py skeletal_quality`"]
    return {"markdown": "\n".join(md), "data": data}


def speed(quick):
    V0, F0 = capsule(0.5, 6.0, 80, 10, 120)
    V, F = loop_subdivide(V0, F0, 1 if quick else 2)
    rest = np.array([_bone((-3.5, 0, 0)), _bone((0, 0, 0))])
    t0 = time.perf_counter()
    rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
    t_bind = time.perf_counter() - t0
    pose = np.array([rest[0], _rot((0, 0, 1), np.pi / 3) @ rest[1]])
    t_ctrl, _ = median_time(lambda: rig.deform_control(pose), repeats=7)
    t_full, _ = median_time(lambda: rig.deform(pose), repeats=7)
    t_nof, _ = median_time(lambda: rig.deform(pose, fairing_steps=0), repeats=7)
    rows = [[len(V), len(F), rig.n_control, len(rig.control_faces), t_bind, 1e3 * t_ctrl, 1e3 * t_nof, 1e3 * t_full]]
    md = ["### Skeletal deformation speed", "",
          table(["dense V", "dense F", "control V", "control F", "bind s", "control deform ms (2 fair)",
                 "full deform ms (no fair)", "full deform ms (2 fair)"], rows), "",
          "Capsule Loop-subdivided; control mesh 5000 faces. Targets: bind <= 10 s for 170K vertices, per pose "
          "<= 20 ms.", "", "`/usr/bin/python3 bench/run.py skeletal_speed`"]
    return {"markdown": "\n".join(md), "data": dict(zip(["V", "F", "control_V", "control_F", "bind_s", "control_ms",
                                                           "full_nofair_ms", "full_ms"], rows[0]))}


WORKLOADS = {"skeletal_quality": quality, "skeletal_speed": speed}
