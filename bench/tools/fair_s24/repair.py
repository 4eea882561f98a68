"""Willmore (default, with min_progress) on fair_repair's 117 regions against the stored
bench/results/fair_repair.json 'willmore' column (a503be1, no min_progress rule); the first N regions
(argument, default 0) also without the rule. Writes $OUT/repair.json; ana.py summarises it."""
import json
import sys

from _case import OUT, REPO, B, regions

B._PER_FACE[0] = 1
old = json.load(open(REPO + "/bench/results/fair_repair.json"))
old = old.get("data", old)
out = {}
check = int(sys.argv[1]) if len(sys.argv) > 1 else 0
for name, V, F, where, frac, patch, _ in regions():
    for kind in ["flat", "dent", "noise"]:
        key = f"{name}/{where}/{frac}/{kind}"
        if key not in old:
            continue
        kw = {"willmore": {}, "willmore:full": {"method": "willmore", "min_progress": 0.0}}
        ms = ("willmore", "willmore:full") if check > 0 else ("willmore",)
        check -= 1
        res = B.repair_case(V, F, patch, kind, methods=ms, cgal=False, smooth=False, **kw)
        w = res["willmore"]
        out[key] = {"new": w[0], "old": old[key]["willmore"], "secs": w[1], "it": w[2]["iterations"],
                    "bil": old[key]["bilaplacian"], "cgal": old[key].get("cgal_fair"),
                    "restarted": w[2]["restarted"], "status": w[2]["status"]}
        if "willmore:full" in res:
            f = res["willmore:full"]
            out[key].update(full=f[0], full_secs=f[1], full_it=f[2]["iterations"])
        print(key, json.dumps(out[key]), flush=True)
json.dump(out, open(OUT + "/repair.json", "w"), indent=1)
