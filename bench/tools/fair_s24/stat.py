"""Triangle-shape statistics of each damaged region (the start selector's candidates) beside which
start was closer, from exp.py's $OUT/exp_seed$SEED.json. Writes $OUT/stat_seed$SEED.json."""
import json

import numpy as np
from _case import OUT, SEED, B, regions

d = json.load(open(f"{OUT}/exp_seed{SEED}.json"))


def q(V, F):
    a = V[F[:, 1]] - V[F[:, 0]]; b = V[F[:, 2]] - V[F[:, 0]]; c = V[F[:, 2]] - V[F[:, 1]]
    A = 0.5 * np.linalg.norm(np.cross(a, b), axis=1)
    return 4 * np.sqrt(3) * A / ((a * a).sum(1) + (b * b).sum(1) + (c * c).sum(1)), A


out = {}
for name, V, F, where, frac, patch, region in regions():
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
json.dump(out, open(f"{OUT}/stat_seed{SEED}.json", "w"))
