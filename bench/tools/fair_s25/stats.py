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
                        planar=float(sv[2] / sv[0]), rimdev=rimdev)
json.dump(out, open(f"{OUT}/stats_seed{SEED}.json", "w"))
