"""cone.py with compact patches (issue 33, session 28): the dense faces of bench skeletal_speed's
178K capsule split at rest into patches of at most LEAF faces (median splits of the face centres
along their widest axis); patches RINGS apart or closer (sharing a vertex, or through one patch
between them) are searched only when the cone of their normals is 90 degrees or wider, the others
whenever their posed boxes meet. Prints recall of the true pairs and the face pairs searched.

    /usr/bin/python3 bench/tools/skeletal_s28/cone_patches.py [LEAF=64] [RINGS=1]
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import _rot, ramp_weights, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

LEAF = int(sys.argv[1]) if len(sys.argv) > 1 else 64
V, F, rest, _, _ = speed_capsule()
# rest-pose patches: median splits of face centroids
C = V[F].mean(1)
g = np.zeros(len(F), int); nxt = [0]
def split(idx, depth=0):
    if len(idx) <= LEAF:
        g[idx] = nxt[0]; nxt[0] += 1; return
    ext = C[idx].max(0) - C[idx].min(0); ax = ext.argmax()
    o = idx[np.argsort(C[idx, ax])]; h = len(o) // 2
    split(o[:h]); split(o[h:])
split(np.arange(len(F)))
G = nxt[0]
# patch adjacency by shared vertex
vp = {}
pairs_adj = set()
order = np.argsort(F.ravel(), kind="stable")
fv = F.ravel()[order]; fg = np.repeat(g, 3)[order]
starts = np.r_[0, np.nonzero(np.diff(fv))[0] + 1, len(fv)]
for a, b in zip(starts[:-1], starts[1:]):
    u = np.unique(fg[a:b])
    for i in range(len(u)):
        for j in range(i + 1, len(u)): pairs_adj.add((u[i], u[j]))
nb = [set() for _ in range(int(g.max()) + 1)]
for p, q in pairs_adj: nb[p].add(q); nb[q].add(p)
RINGS = int(sys.argv[2]) if len(sys.argv) > 2 else 1
adj = set(pairs_adj)
if RINGS >= 2:
    for p in range(len(nb)):
        for q in nb[p]:
            for r in nb[q]:
                if r != p: adj.add((min(p, r), max(p, r)))
size = np.bincount(g, minlength=G)
print("patches", G, "adjacent pairs", len(adj))
for wname, W in (("Gaussian", None), ("ramp", ramp_weights(V))):
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
    for deg in (60, 90, 135):
        pose = np.array([rest[0], _rot((0, 0, 1), np.radians(deg)) @ rest[1]])
        X = rig.deform(pose)
        P = self_intersecting_pairs(X, F)
        n = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        axis = np.zeros((G, 3)); np.add.at(axis, g, n)
        axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
        ang = np.arccos(np.clip((n * axis[g]).sum(1), -1, 1))
        half = np.zeros(G); np.maximum.at(half, g, ang)
        lo = np.full((G, 3), np.inf); hi = np.full((G, 3), -np.inf)
        np.minimum.at(lo, g, X[F].min(1)); np.maximum.at(hi, g, X[F].max(1))
        selfp = set((p, p) for p in np.nonzero(half >= np.pi / 2)[0])
        flagged = set()
        for p, q in adj:
            between = np.arccos(np.clip(axis[p] @ axis[q], -1, 1))
            if max(half[p], half[q], (between + half[p] + half[q]) / 2) >= np.pi / 2:
                flagged.add((p, q))
        far = set()
        for p in range(G):
            m = ~((lo[p + 1:] > hi[p]).any(1) | (lo[p] > hi[p + 1:]).any(1))
            for q in np.nonzero(m)[0] + p + 1:
                if (p, int(q)) not in adj: far.add((p, int(q)))
        cand = flagged | far | selfp
        gp = [tuple(sorted((g[i], g[j]))) for i, j in P]
        recall = np.mean([c in cand for c in gp]) if len(gp) else 1.0
        work = sum(size[p] * size[q] for p, q in cand)
        print(wname, deg, "pairs", len(P), "recall %.4f" % recall, "self", len(selfp), "flagged adj", len(flagged), "far", len(far), "face pairs %.2fM" % (work / 1e6), flush=True)
