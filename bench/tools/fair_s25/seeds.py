"""The default (Willmore flow) against the bilaplacian flow and CGAL fair on fair_repair's places at
other seeds of region_centre (issue 30: "several seeds"), from bench/tools/fair_s24/exp.py's
$OUT/exp_seed$SEED.json (run with K=flat,dent,noise METH=willmore,bilaplacian). Arguments: seeds."""
import json
import os
import sys

import numpy as np

OUT = os.environ.get("OUT", "/tmp/dgmesh-fair-s24")


def verdict(a, b):
    return "tied" if abs(a - b) <= 0.05 * min(a, b) else ("won" if a < b else "lost")


for seed in sys.argv[1:]:
    d = json.load(open(f"{OUT}/exp_seed{seed}.json"))
    for kind in ("flat", "dent", "noise", "all"):
        ks = [k for k in d if kind == "all" or k.endswith("/" + kind)]
        line = f"seed {seed} {kind:5s} n={len(ks):3d} Willmore {np.mean([d[k]['willmore'] for k in ks]):.5f}"
        for p in ("bilaplacian", "cgal_fair", "damaged"):
            t = {"won": 0, "tied": 0, "lost": 0}
            for k in ks:
                t[verdict(d[k]["willmore"], d[k][p])] += 1
            line += f"; vs {p} {t['won']}/{t['tied']}/{t['lost']} ({np.mean([d[k][p] for k in ks]):.5f})"
        print(line)
