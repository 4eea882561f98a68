from pathlib import Path as _Path
REPO = str(_Path(__file__).resolve().parents[3])  # the checkout this script lies in
OUT = __import__("os").environ.get("OUT", "/tmp/dgmesh-fair-s24")  # where its data goes
# Willmore (default, now with min_progress) on fair_repair's 117 regions, against the stored
# bench/results/fair_repair.json 'willmore' column (a503be1, no min_progress rule).
import sys, json
sys.path.insert(0, REPO); sys.path.insert(0, sys.argv[1])
from bench.workloads import fair as B
B._PER_FACE[0] = 1
old = json.load(open(REPO + '/bench/results/fair_repair.json'))
old = old.get('data', old)
out = {}
check = int(sys.argv[2]) if len(sys.argv) > 2 else 0
for name in B._REPAIR_MESHES:
    V, F = B.cgal_mesh(name)
    for where in ["tip", "saddle", "flat"]:
        centre = B.region_centre(V, F, where)
        for frac in [0.02, 0.06, 0.12]:
            patch = B.vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
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
json.dump(out, open(OUT + '/repair.json', 'w'), indent=1)
