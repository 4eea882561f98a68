"""Session 23: (sigma, detail) of the current build for every row of two sweep.py outputs (seeds 11, 31) and the
clean meshes of a clean_scans.py output. Usage: estimates.py OUT.json SWEEP11.json SWEEP31.json CLEAN.json."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from bench.common import cgal_dir
from rows import sweep_rows
out = {"sweep11": {}, "sweep31": {}, "clean": {}}
for lab, f, seed0 in (("sweep11", sys.argv[2], 11), ("sweep31", sys.argv[3], 31)):
    for key, v, Vn, F in sweep_rows(json.load(open(f)), seed0):
        e = dgmesh.estimate_noise(Vn, F)
        out[lab][key] = dict(sigma=e.sigma, detail=e.detail, taubin=v["taubin"])
    print(lab, "done", flush=True)
for name in json.load(open(sys.argv[4])):
    V, F = dgmesh.read_mesh(cgal_dir() / f"{name}.off")
    e = dgmesh.estimate_noise(np.asarray(V, float), np.asarray(F))
    out["clean"][name] = dict(sigma=e.sigma, detail=e.detail)
json.dump(out, open(sys.argv[1], "w"))
print("clean done")
