"""Would normal cones over the multiresolution layer's groups find the dense crossing pairs cheaply?
(issue 33, session 28; numpy, no timing). On bench skeletal_speed's 178K capsule (5000-face control
mesh), the dense faces grouped by the base control face of their first vertex (mr_face). A group
pair needs face-level tests when (a) the two are adjacent (share a control vertex) and the cone of
their normals is 90 degrees or wider (a patch whose normals stay within a narrower cone does not
cross itself; Volino and Magnenat-Thalmann's contour condition is not checked), or (b) they are not
adjacent and their boxes meet. Prints the recall of the true pairs and the face pairs those group
pairs hold.

    /usr/bin/python3 bench/tools/skeletal_s28/cone.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import _rot, ramp_weights, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F, rest, _, _ = speed_capsule()
for wname, W in (("Gaussian", None), ("ramp", ramp_weights(V))):
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
    a = rig.to_arrays()
    mr_face = np.asarray(a["mr_face"]); Fc = np.asarray(a["mr_control_F"]); Fd = np.asarray(a["mr_dense_F"]) if "mr_dense_F" in a else F
    g = mr_face[Fd[:, 0]]
    G = len(Fc)
    # control-face adjacency by shared vertex
    vf = [[] for _ in range(Fc.max() + 1)]
    for f, tri in enumerate(Fc):
        for v in tri: vf[v].append(f)
    adj = [set() for _ in range(G)]
    for fl in vf:
        for f in fl: adj[f].update(fl)
    for deg in (60, 90, 135):
        pose = np.array([rest[0], _rot((0, 0, 1), np.radians(deg)) @ rest[1]])
        X = rig.deform(pose)
        P = self_intersecting_pairs(X, Fd)
        n = np.cross(X[Fd[:, 1]] - X[Fd[:, 0]], X[Fd[:, 2]] - X[Fd[:, 0]])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        axis = np.zeros((G, 3)); np.add.at(axis, g, n)
        axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
        ang = np.arccos(np.clip((n * axis[g]).sum(1), -1, 1))
        half = np.zeros(G); np.maximum.at(half, g, ang)
        lo = np.full((G, 3), np.inf); hi = np.full((G, 3), -np.inf)
        np.minimum.at(lo, g, X[Fd].min(1)); np.maximum.at(hi, g, X[Fd].max(1))
        # (a) flagged pairs among adjacent groups: union cone >= 90
        flagged = set()
        for p in range(G):
            for q in adj[p]:
                if q < p: continue
                between = np.arccos(np.clip(axis[p] @ axis[q], -1, 1))
                if max(half[p], half[q], (between + half[p] + half[q]) / 2) >= np.pi / 2:
                    flagged.add((p, q))
        # (b) non-adjacent groups with meeting boxes
        meet = ~((lo[:, None] > hi[None]).any(2) | (lo[None] > hi[:, None]).any(2))
        far = set()
        for p in range(G):
            for q in np.nonzero(meet[p, p + 1:])[0] + p + 1:
                if q not in adj[p]: far.add((p, int(q)))
        cand = flagged | far
        gp = [tuple(sorted((g[i], g[j]))) for i, j in P]
        recall = np.mean([c in cand for c in gp]) if len(gp) else 1.0
        size = np.bincount(g, minlength=G)
        work = sum(size[p] * size[q] for p, q in cand)
        print(wname, deg, "pairs", len(P), "recall %.4f" % recall, "flagged adjacent", len(flagged), "far", len(far),
              "face pairs to box-test %.2fM (all adjacent-group pairs %.2fM)" % (work / 1e6, sum(size[p] * size[q] for p in range(G) for q in adj[p] if q >= p) / 1e6), flush=True)
