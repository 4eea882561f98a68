"""Distances of the hinge / Willmore results from the uniform and the cotangent start (and the
bilaplacian flow, CGAL fair) on fair_repair's regions. Environment: M meshes, W places, K damage kinds,
FR fractions, METH methods (comma-separated), SEED region_centre's seed. Writes $OUT/exp_seed$SEED.json."""
import json
import os

from _case import OUT, SEED, B, dgmesh, regions

B._PER_FACE[0] = 1
env = os.environ.get
meshes = env("M", ",".join(B._REPAIR_MESHES)).split(",")
wheres = env("W", "tip,saddle,flat").split(",")
kinds = env("K", "dent").split(",")
fracs = [float(x) for x in env("FR", "0.02,0.06,0.12").split(",")]
methods = env("METH", "hinge,hinge:cot,willmore,willmore:cot,bilaplacian").split(",")
kw = {"hinge:cot": {"method": "hinge", "start_weights": "cotangent"},
      "willmore:cot": {"method": "willmore", "start_weights": "cotangent"},
      "hinge:cotnl": {"method": "hinge", "start_weights": "cotangent", "max_iterations": 0}}
out = {}
for name, V, F, where, frac, patch, _ in regions(meshes, wheres, fracs):
    for kind in kinds:
        try:
            res = B.repair_case(V, F, patch, kind, methods=methods, cgal=True, smooth=False, **kw)
        except dgmesh.MeshError:
            continue
        key = f"{name}/{where}/{frac}/{kind}"
        out[key] = {m: res[m][0] for m in res}
        print(key, " ".join(f"{m}={res[m][0]:.4g}" for m in res), flush=True)
json.dump(out, open(f"{OUT}/exp_seed{SEED}.json", "w"))
