"""Whether the rim's curvature tells where the default Willmore flow moves a region away from its
linear start (issue 30, session 25): per fair_repair region (seed $SEED), the two fixed rings' mean
|H| times the rim's mean radius (dimensionless), their mean |H| over their mean |k1 - k2|, beside
flowgain.py's distances. Prints the split; reads $OUT/flowgain_seed$SEED.json."""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import OUT, SEED, B, dgmesh, regions  # noqa: E402

d = json.load(open(f"{OUT}/flowgain_seed{SEED}.json"))
rows = []
for name, V, F, where, frac, patch, region in regions():
    c = dgmesh.curvature(V, F)
    H, K = np.abs(c.mean), c.gaussian
    rim = B._region_of(F, patch)[1]
    ring2 = np.zeros(len(V), bool)
    ring2[F[rim[F].any(1)].ravel()] = True
    rings = (rim | ring2) & ~patch
    R = np.linalg.norm(V[rim] - V[rim].mean(0), axis=1).mean()
    for kind in ["flat", "dent", "noise"]:
        key = f"{name}/{where}/{frac}/{kind}"
        if key not in d:
            continue
        x = d[key]
        rows.append((key, float(H[rings].mean() * R), float(np.median(H[rings]) * R), x["flow"], x["lin"], x["bilaplacian"]))
rows.sort(key=lambda r: r[1])
for r in rows:
    tag = "flow" if r[3] < 0.95 * r[5] else ("bilap" if r[5] < 0.95 * r[3] else "tie")
    print(f"{r[0]:28s} HR {r[1]:.3f} medHR {r[2]:.3f} flow {r[3]:.4f} bilap {r[5]:.4f} closer: {tag}")
