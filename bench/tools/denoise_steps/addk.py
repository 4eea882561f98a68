"""Step 2: adds the estimates of 12 / 27 / 36-point fits (s12, s27, s36, c36) to a sweep JSON.
Usage: addk.py SWEEP.json SEED (writes SWEEPk.json)."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from rows import sweep_rows
f, seed0 = sys.argv[1], int(sys.argv[2])
d = json.load(open(f))
for key, v, Vn, F in sweep_rows(d, seed0):
    for k in (12, 27, 36):
        e = dgmesh.estimate_noise(Vn, F, neighbours=k); v[f"s{k}"] = e.sigma; v[f"c{k}"] = e.curvature
    print(key, int(np.argmin(v["taubin"])), " ".join(f"{v[x]:.3f}" for x in ("s12", "sigma", "s27", "s36", "c36")), flush=True)
json.dump(d, open(f.replace(".json", "k.json"), "w"))
