"""Held-out check of the step rule: rows of sweep31 (models not used in the fit, seed 31)."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from rows import sweep_rows
d = json.load(open(sys.argv[1])); seed0 = int(sys.argv[2])
old_r, new_r = [], []
for key, v, Vn, F in sweep_rows(d, seed0):
    e = dgmesh.estimate_noise(Vn, F)
    t = np.array(v["taubin"])
    new = dgmesh.denoising._native.auto_smoothing_steps(e)
    old = int(round(min(40, 28.6 * e.sigma ** 1.62 / max(e.curvature, 0.05) ** 2)))
    old_r.append(t[old] / t.min()); new_r.append(t[new] / t.min())
    print(f"{key:30s} best {t.argmin():2d} {t.min():.3f} | old {old:2d} {t[old]:.3f} | new {new:2d} {t[new]:.3f} (detail {e.detail:.3f})", flush=True)
lo, ln = np.log(old_r), np.log(new_r)
print(f"mean excess over the best count: old {np.exp(lo.mean()) - 1:.3%} (max {max(old_r) - 1:.1%}), new {np.exp(ln.mean()) - 1:.3%} (max {max(new_r) - 1:.1%}) over {len(old_r)} rows")
