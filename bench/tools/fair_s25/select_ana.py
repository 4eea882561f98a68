"""Summary of select.py's data: mean distance / diagonal of the uniform start, the cotangent start,
the shape rule (cotangent when stat >= THR, default 1) and the oracle, per damage kind and overall,
and won/tied/lost (5%) of the rule against the uniform start. Arguments: seeds (default 0 19);
PREFIX=willmore (or hinge) picks the method's columns."""
import json
import os
import sys

import numpy as np

OUT = os.environ.get("OUT", "/tmp/dgmesh-fair-s25")
pre = os.environ.get("PREFIX", "willmore")
thr = float(os.environ.get("THR", "1"))
for seed in sys.argv[1:] or ["0", "19"]:
    d = json.load(open(f"{OUT}/select_seed{seed}.json"))
    print(f"seed {seed}: {len(d)} regions, rule: cotangent start when stat >= {thr}")
    for kind in ["flat", "dent", "noise", "all"]:
        ks = [k for k in d if kind == "all" or k.endswith("/" + kind)]
        u = np.array([d[k][pre + ":uni"] for k in ks])
        c = np.array([d[k][pre + ":cot"] for k in ks])
        s = np.array([d[k]["stat"] for k in ks])
        r = np.where(s >= thr, c, u)
        wtl = [int(np.sum((r < u) & (np.abs(r - u) > 0.05 * np.minimum(r, u)))), 0,
               int(np.sum((r > u) & (np.abs(r - u) > 0.05 * np.minimum(r, u))))]
        wtl[1] = len(ks) - wtl[0] - wtl[2]
        line = (f"  {kind:5s} n={len(ks):3d} uniform {u.mean():.5f} cotangent {c.mean():.5f} rule {r.mean():.5f} "
                f"oracle {np.minimum(u, c).mean():.5f}  rule vs uniform {wtl[0]}/{wtl[1]}/{wtl[2]}  cot picked {int((s >= thr).sum())}")
        print(line)
