"""Step 1 of the step-rule fit (bench/notes/denoise.md): per noisy mesh, the normal error after every
Taubin step (0-60) and every Blender-like Smooth step (0-20), with the noise estimate.
Usage: sweep.py MODELS LEVELS SEED OUT.json (from the repository root)."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np
from bench.workloads.denoise import normal_error
from rows import sweep_inputs

def umbrella(F, n):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E = np.sort(E, axis=1); E = np.unique(E[E[:, 0] != E[:, 1]], axis=0)
    deg = np.bincount(E.ravel(), minlength=n).astype(float)
    def L(P):
        S = np.zeros_like(P)
        np.add.at(S, E[:, 0], P[E[:, 1]]); np.add.at(S, E[:, 1], P[E[:, 0]])
        m = deg > 0
        out = np.zeros_like(P); out[m] = S[m] / deg[m, None] - P[m]
        return out
    return L

def curves(V, F, Vn, maxT=60, maxS=20):
    L = umbrella(F, len(V))
    P = Vn.copy(); t = [normal_error(P, V, F)]
    for s in range(maxT):
        P = P + 0.6 * L(P); P = P - 0.62 * L(P); t.append(normal_error(P, V, F))
    P = Vn.copy(); sm = [t[0]]
    for s in range(maxS):
        P = P + 0.5 * L(P); sm.append(normal_error(P, V, F))
    return np.array(t), np.array(sm)

out = {}
models = sys.argv[1].split(","); levels = [float(x) for x in sys.argv[2].split(",")]
seed0 = int(sys.argv[3]) if len(sys.argv) > 3 else 11
for key, V, F, Vn, est in sweep_inputs(models, levels, seed0):
    t, sm = curves(V, F, Vn)
    out[key] = dict(sigma=est.sigma, curv=est.curvature, outl=est.outliers, taubin=t.tolist(), smooth=sm.tolist())
    print(f"{key:35s} sig {est.sigma:.3f} curv {est.curvature:.2f} | taubin best {t.argmin():2d} {t.min():.3f} | smooth best {sm.argmin():2d} {sm.min():.3f}", flush=True)
json.dump(out, open(sys.argv[4] if len(sys.argv) > 4 else "/tmp/dn/sweep.json", "w"))
