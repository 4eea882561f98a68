"""Probe of issue 33's crease self-intersections on a capsule (no Blender needed): where in the
deform the self-intersecting triangle pairs of a bent joint arise, and which of them are limb
against limb. Gaussian weights (the rig's own, bind without weights), not Blender's automatic
weights of bench skeletal_limb; DQS = skeletal_subspace_deform(dual_quaternion=True) of the mesh
with the same weights.

    /usr/bin/python3 bench/tools/skeletal_crease_probe.py

self_intersecting_pairs() counts pairs of triangles sharing no vertex where an edge of one crosses
the other's interior (non-coplanar crossings), over the faces whose rest centroid lies within 2.2
of the joint (the whole capsule's count is the same here). Checked against Blender's
BVHTree.overlap (bench/workloads/_skeletal_overlap.py) on the 64 x 10 x 128 capsule: ours 45 / 90
degrees 558 / 2918 both, DQS 0 / 201 against Blender's 0 / 199.
"""

import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "addon"))
import dgmesh  # noqa: E402
from dgmesh.skeletal import capsule, skeletal_subspace_deform  # noqa: E402


def _vol(a, b, c, d):
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))


def _seg_hits_tri(p, q, a, b, c):
    s1, s2 = _vol(p, a, b, c), _vol(q, a, b, c)
    cross = ((s1 > 0) & (s2 < 0)) | ((s1 < 0) & (s2 > 0))
    u, v, w = _vol(p, q, a, b), _vol(p, q, b, c), _vol(p, q, c, a)
    return cross & (((u > 0) & (v > 0) & (w > 0)) | ((u < 0) & (v < 0) & (w < 0)))


def self_intersecting_pairs(V, F, faces=None):
    """(I, J): face indices of the intersecting pairs among `faces` (a mask; all when None)."""
    idx = np.arange(len(F)) if faces is None else np.flatnonzero(faces)
    F2 = F[idx]
    T = V[F2]
    lo, hi = T.min(1), T.max(1)
    cell = (hi - lo).max()  # a box spans at most two cells per axis: neighbouring cells suffice
    key3 = np.floor(lo / cell).astype(np.int64)
    key3 -= key3.min(0)
    dims = key3.max(0) + 3
    key = (key3[:, 0] * dims[1] + key3[:, 1]) * dims[2] + key3[:, 2]
    order = np.argsort(key, kind="stable")
    sk = key[order]
    I, J = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                k = key + (dx * dims[1] + dy) * dims[2] + dz
                s, e = np.searchsorted(sk, k, "left"), np.searchsorted(sk, k, "right")
                cnt = e - s
                ii = np.repeat(np.arange(len(F2)), cnt)
                off = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
                jj = order[np.repeat(s, cnt) + off]
                m = ii < jj
                I.append(ii[m])
                J.append(jj[m])
    I, J = np.concatenate(I), np.concatenate(J)
    ok = np.all((lo[I] <= hi[J]) & (lo[J] <= hi[I]), axis=1)
    I, J = I[ok], J[ok]
    share = np.zeros(len(I), bool)
    for a in range(3):
        for b in range(3):
            share |= F2[I, a] == F2[J, b]
    I, J = I[~share], J[~share]
    hit = np.zeros(len(I), bool)
    A, B = T[I], T[J]
    for X, Y in ((A, B), (B, A)):
        for k in range(3):
            hit |= _seg_hits_tri(X[:, k], X[:, (k + 1) % 3], Y[:, 0], Y[:, 1], Y[:, 2])
    return idx[I[hit]], idx[J[hit]]


def bone(head):
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (0, -1, 0), (1, 0, 0), (0, 0, 1), head
    return m


def rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    return m


REST = np.array([bone((-3.5, 0, 0)), bone((0, 0, 0))])
HEADS = np.array([[-3.5, 0, 0], [0, 0, 0.0]])
TAILS = np.array([[0, 0, 0], [3.5, 0, 0.0]])


def probe_rigs(V, F):
    """The capsule bound with the rig's Gaussian weights, whole and through a 5000-face control mesh
    (the untangle, twist and fold guard probes)."""
    return {path: dgmesh.SkeletalRig.bind(V, F, REST, None, bone_heads=HEADS, bone_tails=TAILS, control_faces=cf)
            for path, cf in (("whole", len(F) + 1), ("multires", 5000))}


def probe_poses():
    """Bends of 45 / 90 / 135 degrees and twists of 90 / 180 of the second bone: name -> rotation."""
    poses = {f"bend {a}": rot((0, 0, 1), np.radians(a)) for a in (45, 90, 135)}
    poses.update({f"twist {a}": rot((1, 0, 0), np.radians(a)) for a in (90, 180)})
    return poses


def bone_ratio_min(X, V, pose):
    def seg(P, a, b):
        ab = b - a
        t = np.clip((P - a) @ ab / (ab @ ab), 0, 1)
        return np.linalg.norm(a + t[:, None] * ab - P, axis=1)

    def dist(P, pz):
        out = []
        for j in range(2):
            A = pz[j] @ np.linalg.inv(REST[j])
            out.append(seg(P, A[:3, :3] @ HEADS[j] + A[:3, 3], A[:3, :3] @ TAILS[j] + A[:3, 3]))
        return np.min(out, 0)

    d0 = dist(V, REST)
    ok = d0 > 1e-9
    return float((dist(X[ok], pose) / d0[ok]).min())


def main():
    V, F = capsule(0.5, 6.0, 64, 10, 128)
    rig = dgmesh.SkeletalRig.bind(V, F, REST, None, bone_heads=HEADS, bone_tails=TAILS, control_faces=len(F) + 1)
    rig_mr = dgmesh.SkeletalRig.bind(V, F, REST, None, bone_heads=HEADS, bone_tails=TAILS, control_faces=5000)
    near = np.linalg.norm(V[F].mean(1), axis=1) < 2.2
    side = np.sign(V[:, 0]).astype(int)
    fs = side[F].sum(1)
    fside = np.where(fs == 3, 1, np.where(fs == -3, -1, 0))  # parent (-1) / child (+1) side at rest, 0 = straddles

    def report(label, X, pose):
        I, J = self_intersecting_pairs(X, F, near)
        cls = Counter(tuple(sorted(p)) for p in zip(fside[I], fside[J]))
        limb = cls[(-1, 1)]
        print("%-44s pairs %5d  limb-vs-limb %5d  same limb %5d  min bone ratio %.3f"
              % (label, len(I), limb, len(I) - limb, bone_ratio_min(X, V, pose)), flush=True)

    for ang in (45, 90, 135):
        pose = np.array([REST[0], rot((0, 0, 1), np.radians(ang)) @ REST[1]])
        print("bend %d" % ang)
        report("  DQS", skeletal_subspace_deform(V, rig.weights, REST, pose, dual_quaternion=True), pose)
        report("  LBS", skeletal_subspace_deform(V, rig.weights, REST, pose), pose)
        report("  ours, contact_slide=3", rig.deform(pose, contact_slide=3), pose)
        report("  ours, default (contact_slide=0)", rig.deform(pose), pose)
        report("  ours via multires (5000 faces), contact_slide=3", rig_mr.deform(pose, contact_slide=3), pose)
        report("  ours via multires, contact_slide=0", rig_mr.deform(pose, contact_slide=0), pose)
        report("  bare reconstruction (fairing_steps=0)", rig.deform(pose, fairing_steps=0), pose)
        for cs in (0, 3):
            report("  2 fairing steps, projection=0, slide %g" % cs, rig.deform(pose, projection=0, contact_slide=cs), pose)
            report("  1 fairing step, projection=0, slide %g" % cs,
                   rig.deform(pose, fairing_steps=1, projection=0, contact_slide=cs), pose)
            report("  2 steps of 0.5, projection=0, slide %g" % cs,
                   rig.deform(pose, fairing_step=0.5, projection=0, contact_slide=cs), pose)
        for cs in (1.5, 2, 5):
            report("  ours, contact_slide=%g" % cs, rig.deform(pose, contact_slide=cs), pose)
    for ang in (90, 180):
        pose = np.array([REST[0], rot((1, 0, 0), np.radians(ang)) @ REST[1]])
        f0 = dgmesh.union_of_balls_distance(V, rig.skeleton_vertices, rig.radii)
        _, Sd = rig.deform_control(pose)
        for label, X in (("default", rig.deform(pose)), ("contact_slide=3", rig.deform(pose, contact_slide=3)),
                         ("1 fairing step, projection=0", rig.deform(pose, fairing_steps=1, projection=0))):
            f = dgmesh.union_of_balls_distance(X, Sd, rig.radii)
            print("twist %d %-32s sum (f - f_rest)^2 %.3g  min bone ratio %.3f"
                  % (ang, label, ((f - f0) ** 2).sum(), bone_ratio_min(X, V, pose)))


if __name__ == "__main__":
    main()
