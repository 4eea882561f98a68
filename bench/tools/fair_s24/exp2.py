import sys, json
from pathlib import Path as _Path
REPO = str(_Path(__file__).resolve().parents[3])  # the checkout this script lies in
OUT = __import__("os").environ.get("OUT", "/tmp/dgmesh-fair-s24")  # where its data goes
sys.path.insert(0, REPO); sys.path.insert(0, REPO + '/addon')
import dgmesh
from bench.workloads import fair as B
B._PER_FACE[0] = 1
out = {}
for name in B._REPAIR_MESHES:
    V, F = B.cgal_mesh(name)
    diag = B.bbox_diagonal(V)
    for where in ["tip", "saddle", "flat"]:
        centre = B.region_centre(V, F, where)
        for frac in [0.02, 0.06, 0.12]:
            patch = B.vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
            region, _ = B._region_of(F, patch)
            for kind in ["flat", "dent", "noise"]:
                W = B.damage(V, F, patch, kind)
                row = {}
                try:
                    for sw in ["uniform", "cotangent"]:
                        r = dgmesh.fair(W, F, mask=patch, method="hinge", start_weights=sw)
                        d = B.patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0] / diag
                        row[sw] = (d, float(r.energy[1]) if len(r.energy) > 1 else None, float(r.energy[-1]), r.iterations)
                except dgmesh.MeshError:
                    continue
                key = f"{name}/{where}/{frac}/{kind}"
                out[key] = row
                print(key, row, flush=True)
json.dump(out, open(OUT + "/energies.json", "w"))
