import sys, json
from pathlib import Path as _Path
REPO = str(_Path(__file__).resolve().parents[3])  # the checkout this script lies in
OUT = __import__("os").environ.get("OUT", "/tmp/dgmesh-fair-s24")  # where its data goes
sys.path.insert(0, REPO); sys.path.insert(0, REPO + '/addon')
import numpy as np
from bench.workloads import fair as B
d = json.load(open(OUT + "/seed19.json"))
def q(V, F):
    a = V[F[:, 1]] - V[F[:, 0]]; b = V[F[:, 2]] - V[F[:, 0]]; c = V[F[:, 2]] - V[F[:, 1]]
    A = 0.5 * np.linalg.norm(np.cross(a, b), axis=1)
    return 4 * np.sqrt(3) * A / ((a * a).sum(1) + (b * b).sum(1) + (c * c).sum(1)), A
out = {}
for name in B._REPAIR_MESHES:
    V, F = B.cgal_mesh(name)
    for where in ["tip", "saddle", "flat"]:
        centre = B.region_centre(V, F, where, seed=19)
        for frac in [0.02, 0.06, 0.12]:
            patch = B.vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
            region, _ = B._region_of(F, patch)
            ring = np.zeros(len(V), bool); ring[F[region].ravel()] = True
            ring2 = ring[F].any(1) & ~region
            for kind in ["flat", "dent", "noise"]:
                key = f"{name}/{where}/{frac}/{kind}"
                if key not in d: continue
                W = B.damage(V, F, patch, kind)
                qi, Ai = q(W, F[region]); qr, Ar = q(W, F[ring2]); qo, Ao = q(V, F[region])
                s = dict(qratio=float(qi.mean() / qr.mean()), arearatio=float(Ai.sum() / Ao.sum()),
                         minq=float(np.percentile(qi, 5) / np.percentile(qr, 5)),
                         meanA=float(Ai.mean() / Ar.mean()))
                v = d[key]
                s["cot_better"] = v["hinge:cot"] < 0.95 * v["hinge"]; s["uni_better"] = v["hinge"] < 0.95 * v["hinge:cot"]
                out[key] = s
                print(key, {k: (round(x, 3) if isinstance(x, float) else x) for k, x in s.items()}, flush=True)
json.dump(out, open(OUT + "/stat19.json", "w"))
