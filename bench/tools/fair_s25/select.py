"""The start selector's data (issue 30, session 25): on fair_repair's regions (seed $SEED of
region_centre) and damage kinds, the default Willmore flow's distance from the uniform and from the
cotangent start, and the selector's statistic: the 5th percentile of the triangle shape quality
4 sqrt(3) A / sum l^2 of the damaged region's faces over that of the ring of faces around it (the
cotangent start when >= 1). Environment: M meshes, K kinds, METH extra methods (comma-separated).
Writes $OUT/select_seed$SEED.json."""
import json
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import OUT, SEED, B, dgmesh, regions  # noqa: E402

B._PER_FACE[0] = 1
env = os.environ.get
meshes = env("M", ",".join(B._REPAIR_MESHES)).split(",")
kinds = env("K", "flat,dent,noise").split(",")
methods = ["willmore:uni", "willmore:cot"] + [m for m in env("METH", "").split(",") if m]
kw = {"willmore:uni": {"method": "willmore", "start_weights": "uniform"},
      "willmore:cot": {"method": "willmore", "start_weights": "cotangent"},
      "hinge:uni": {"method": "hinge", "start_weights": "uniform"},
      "hinge:cot": {"method": "hinge", "start_weights": "cotangent"}}


def quality(V, F):
    a, b, c = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 1]]
    A = 0.5 * np.linalg.norm(np.cross(a, b), axis=1)
    return 4 * np.sqrt(3) * A / ((a * a).sum(1) + (b * b).sum(1) + (c * c).sum(1))


out = {}
for name, V, F, where, frac, patch, region in regions(meshes):
    ring = np.zeros(len(V), bool)
    ring[F[region].ravel()] = True
    around = ring[F].any(1) & ~region
    for kind in kinds:
        W = B.damage(V, F, patch, kind)
        stat = float(np.percentile(quality(W, F[region]), 5) / np.percentile(quality(W, F[around]), 5))
        try:
            res = B.repair_case(V, F, patch, kind, methods=methods, cgal=False, smooth=False, **kw)
        except dgmesh.MeshError:
            continue
        key = f"{name}/{where}/{frac}/{kind}"
        out[key] = {m: res[m][0] for m in res}
        out[key]["stat"] = stat
        print(key, f"stat={stat:.3f}", " ".join(f"{m}={res[m][0]:.4g}" for m in res), flush=True)
json.dump(out, open(f"{OUT}/select_seed{SEED}.json", "w"))
