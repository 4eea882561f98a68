import sys, os, json
from pathlib import Path as _Path
REPO = str(_Path(__file__).resolve().parents[3])  # the checkout this script lies in
OUT = __import__("os").environ.get("OUT", "/tmp/dgmesh-fair-s24")  # where its data goes
sys.path.insert(0, REPO); sys.path.insert(0, REPO + '/addon')
import dgmesh
from bench.workloads import fair as B
B._PER_FACE[0] = 1
meshes = os.environ.get("M", ",".join(B._REPAIR_MESHES)).split(",")
wheres = os.environ.get("W", "tip,saddle,flat").split(",")
kinds = os.environ.get("K", "dent").split(",")
fracs = [float(x) for x in os.environ.get("FR", "0.02,0.06,0.12").split(",")]
methods = os.environ.get("METH", "hinge,hinge:cot,willmore,willmore:cot,bilaplacian").split(",")
kw = {"hinge:cot": {"method": "hinge", "start_weights": "cotangent"},
      "willmore:cot": {"method": "willmore", "start_weights": "cotangent"},
      "hinge:cotnl": {"method": "hinge", "start_weights": "cotangent", "max_iterations": 0},
      }
out = {}
for name in meshes:
    V, F = B.cgal_mesh(name)
    for where in wheres:
        centre = B.region_centre(V, F, where)
        for frac in fracs:
            patch = B.vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
            for kind in kinds:
                try:
                    res = B.repair_case(V, F, patch, kind, methods=methods, cgal=True, smooth=False, **kw)
                except dgmesh.MeshError:
                    continue
                key = f"{name}/{where}/{frac}/{kind}"
                out[key] = {m: res[m][0] for m in res}
                print(key, " ".join(f"{m}={res[m][0]:.4g}" for m in res), flush=True)
json.dump(out, open(os.environ.get("OUT", OUT + "/out.json"), "w"))
