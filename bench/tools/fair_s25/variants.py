"""The default Willmore flow against variants of its options on fair_repair's regions (seed $SEED):
CONF is a ;-separated list of name=python-dict of dgmesh.fair keyword arguments. Mean distance /
diagonal and won/tied/lost (5%) against the bilaplacian flow, by place. Writes $OUT/variants_seed$SEED.json."""
import ast
import json
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import OUT, SEED, B, dgmesh, distance, regions  # noqa: E402

B._PER_FACE[0] = 1
confs = {"default": {}, "bilaplacian": {"method": "bilaplacian"}}
for item in os.environ.get("CONF", "").split(";"):
    if item:
        name, kw = item.split("=", 1)
        confs[name] = ast.literal_eval(kw)
out = {}
for name, V, F, where, frac, patch, region in regions():
    diag = B.bbox_diagonal(V)
    for kind in ["flat", "dent", "noise"]:
        W = B.damage(V, F, patch, kind)
        try:
            out[f"{name}/{where}/{frac}/{kind}"] = {c: distance(V, F, region, dgmesh.fair(W, F, mask=patch, **kw), diag)
                                                    for c, kw in confs.items()}
        except dgmesh.MeshError:
            continue
json.dump(out, open(f"{OUT}/variants_seed{SEED}.json", "w"))
for c in confs:
    for where in ["tip", "saddle", "flat", ""]:
        ks = [k for k in out if f"/{where}/" in k or not where]
        x = np.array([out[k][c] for k in ks])
        b = np.array([out[k]["bilaplacian"] for k in ks])
        tie = np.abs(x - b) <= 0.05 * np.minimum(x, b)
        print(f"{c:14s} {where or 'all':6s} mean {x.mean():.5f} vs bilaplacian {int(((x < b) & ~tie).sum())}/"
              f"{int(tie.sum())}/{int(((x > b) & ~tie).sum())}")
