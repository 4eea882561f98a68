"""A smooth union of balls for the thickness step (issue 33, session 28): from the bare
reconstruction (fairing_steps=0) of the 48 x 8 x 96 capsule (probe_rigs' whole-mesh rig, Gaussian
weights), three passes of the explicit step towards each vertex's rest value of the union's
distance, with the hard minimum of eq. 6.13 (k = 0) or the soft minimum -k log sum_j exp(-d_j / k),
d_j = |x - s_j| - r_j, k = kappa x the median radius (the rest values with the same k; the step
along the soft minimum's gradient). Per bend: pairs over the whole mesh, minimum bone ratio, sum
(f - f_rest)^2 of the hard minimum; beside them the bare reconstruction and the rig's own steps
(fairing and projection, fold_guard=0, bone_clearance=0).

    cd bench/tools && /usr/bin/python3 skeletal_s28/softmin.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import numpy as np  # noqa: E402

from dgmesh.skeletal import capsule, self_intersecting_pairs  # noqa: E402
from skeletal_crease_probe import REST, bone_ratio_min, probe_poses, probe_rigs  # noqa: E402


def dists(X, S, r, chunk=2000):
    out = np.empty((len(X), len(S)))
    for a in range(0, len(X), chunk):
        out[a:a + chunk] = np.linalg.norm(X[a:a + chunk, None] - S[None], axis=2) - r[None]
    return out


def smin(D, k):
    m = D.min(1, keepdims=True)
    E = np.exp(-(D - m) / k)
    return (m - k * np.log(E.sum(1, keepdims=True)))[:, 0], E / E.sum(1, keepdims=True)


def step(X, S, r, target, k, passes=3):
    X = X.copy()
    for _ in range(passes):
        D = dists(X, S, r)
        if k == 0:
            j = D.argmin(1)
            f = D[np.arange(len(X)), j]
            g = (X - S[j]) / np.linalg.norm(X - S[j], axis=1, keepdims=True)
        else:
            f, P = smin(D, k)
            U = X[:, None] - S[None]
            U /= np.linalg.norm(U, axis=2, keepdims=True)
            g = (P[:, :, None] * U).sum(1)
        X -= ((f - target) / np.maximum((g * g).sum(1), 1e-12))[:, None] * g
    return X


V, F = capsule(0.5, 6.0, 48, 8, 96)
rig = probe_rigs(V, F)["whole"]
S0, r = rig.skeleton_vertices, rig.radii
D0 = dists(V, S0, r)
for name, R in probe_poses().items():
    if not name.startswith("bend"):
        continue
    pose = np.array([REST[0], R @ REST[1]])
    Sd = rig.skeleton_pose(pose)
    bare = rig.deform(pose, fairing_steps=0)
    cells = ["bare %d" % len(self_intersecting_pairs(bare, F)),
             "rig's steps %d" % len(self_intersecting_pairs(rig.deform(pose, fold_guard=0, bone_clearance=0), F))]
    for kappa in (0, 0.05, 0.1, 0.2, 0.4):
        k = kappa * np.median(r)
        X = step(bare, Sd, r, D0.min(1) if k == 0 else smin(D0, k)[0], k)
        thick = ((dists(X, Sd, r).min(1) - D0.min(1)) ** 2).sum()
        cells.append("kappa %.2f: %d (%.3f, %.3g)" % (kappa, len(self_intersecting_pairs(X, F)), bone_ratio_min(X, V, pose), thick))
    print(name, " | ".join(cells), flush=True)
