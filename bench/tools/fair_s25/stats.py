"""Candidate statistics of the damaged input for the start selector (computable by the library from
the input alone), beside select.py's distances: per region and kind, ratios region / ring of faces
around it of the 5th percentile and mean triangle quality, the mean face area, and the mean edge
length. Writes $OUT/stats_seed$SEED.json (keys as select.py's)."""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import OUT, SEED, B, regions  # noqa: E402

d = json.load(open(f"{OUT}/select_seed{SEED}.json"))


def shape(V, F):
    a, b, c = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 1]]
    A = 0.5 * np.linalg.norm(np.cross(a, b), axis=1)
    s = (a * a).sum(1) + (b * b).sum(1) + (c * c).sum(1)
    return 4 * np.sqrt(3) * A / s, A, np.sqrt(s / 3)


def crease(V, F, region, around):
    """Mean dihedral angle (between face normals) over the edges between a region face and a face
    outside, over the mean over the edges inside the faces around the region: > 1 where the region
    meets its surroundings with a crease (a flattened patch, a flat fill)."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    E = np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    fid = np.tile(np.arange(len(F)), 3)
    key = np.sort(E, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, fid = key[order], fid[order]
    same = np.all(key[1:] == key[:-1], axis=1)
    f0, f1 = fid[:-1][same], fid[1:][same]
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", n[f0], n[f1]), -1, 1))
    rim_e = region[f0] != region[f1]
    out_e = around[f0] & around[f1]
    return float(ang[rim_e].mean() / max(ang[out_e].mean(), 1e-300))


out = {}
for name, V, F, where, frac, patch, region in regions():
    rim = B._region_of(F, patch)[1]
    ring = np.zeros(len(V), bool)
    ring[F[region].ravel()] = True
    around = ring[F].any(1) & ~region
    for kind in ["flat", "dent", "noise"]:
        key = f"{name}/{where}/{frac}/{kind}"
        if key not in d:
            continue
        W = B.damage(V, F, patch, kind)
        c, nrm = B._plane(W[rim])
        rimdev = float(np.abs((W[patch] - c) @ nrm).max() / np.linalg.norm(W[rim] - c, axis=1).mean())
        sv = np.linalg.svd(W[patch] - W[patch].mean(0), compute_uv=False)  # thinness of the moved vertices
        qi, Ai, li = shape(W, F[region])
        qo, Ao, lo = shape(W, F[around])
        out[key] = dict(p5q=float(np.percentile(qi, 5) / np.percentile(qo, 5)), meanq=float(qi.mean() / qo.mean()),
                        medq=float(np.median(qi) / np.median(qo)), area=float(Ai.mean() / Ao.mean()),
                        edge=float(li.mean() / lo.mean()), p5q_in=float(np.percentile(qi, 5)),
                        planar=float(sv[2] / sv[0]), rimdev=rimdev, crease=crease(W, F, region, around))
json.dump(out, open(f"{OUT}/stats_seed{SEED}.json", "w"))
