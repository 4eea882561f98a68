"""Issue 30, session 25: the default Willmore flow declines its linear start when the start raises the
discrete energy (a smooth dent is often below it); "forced" always takes it: the bilaplacian flow's
result, then the Willmore flow from there (linear_start=False). On fair_repair's regions (seed $SEED):
mean distance / diagonal and won/tied/lost (5%) against the bilaplacian flow, by damage, for the
default and the forced variant; and how often the default declined its start."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import B, damaged, dgmesh, distance  # noqa: E402

B._PER_FACE[0] = 1
rows = []
for name, V, F, where, frac, patch, region, kind, W, diag in damaged():
    try:
        r = dgmesh.fair(W, F, mask=patch)
        b = dgmesh.fair(W, F, mask=patch, method="bilaplacian")
        f = dgmesh.fair(b.vertices, F, mask=patch, linear_start=False)
    except dgmesh.MeshError:
        continue
    rows.append((kind, where, bool(r.linear_start), distance(V, F, region, r, diag),
                 distance(V, F, region, f, diag), distance(V, F, region, b, diag)))
for kind in ("flat", "dent", "noise", "all"):
    sub = [x for x in rows if kind in (x[0], "all")]
    for label, j in (("default", 3), ("forced", 4)):
        t = {"won": 0, "tied": 0, "lost": 0}
        for x in sub:
            t[B._verdict(x[j], x[5])] += 1
        print(f"{kind:5s} {label:8s} mean {np.mean([x[j] for x in sub]):.5f} (bilaplacian {np.mean([x[5] for x in sub]):.5f}) "
              f"vs bilaplacian {t['won']}/{t['tied']}/{t['lost']}; default declined its start on "
              f"{sum(not x[2] for x in sub)} of {len(sub)}")
