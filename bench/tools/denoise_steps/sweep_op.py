"""Session 25 (bench/notes/denoise.md): the step sweep of sweep.py for the *current* automatic operator
(session 24: Taubin lambda 0.6 / mu -0.62 with W = (1 - c) uniform + c clamped cotangent, c = 0.5,
weights of the noisy input, as native/src/denoise.cpp taubin_smooth), with the current estimate.
Per row: sigma, detail, and the normal error after 0-60 steps. Usage:
sweep_op.py MODELS LEVELS SEED OUT.json [--check] (from the repository root; --check compares a few
counts with the native denoise_mesh with automatic off, iterations 0, smoothing_steps k)."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from bench.workloads.denoise import normal_error
from rows import sweep_inputs

SHARE, LAM, MU = 0.5, 0.6, -0.62


def operator(P, F):
    """(a, b, w_ab, w_ba, degree>0 mask): the half-uniform half-cotangent weights of positions P."""
    n = len(P)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    O = np.concatenate([F[:, 2], F[:, 0], F[:, 1]])
    keep = E[:, 0] != E[:, 1]
    E, O = E[keep], O[keep]
    Es = np.sort(E, axis=1)
    u = P[E[:, 0]] - P[O]; v = P[E[:, 1]] - P[O]
    area2 = np.linalg.norm(np.cross(u, v), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = 0.5 * np.einsum("ij,ij->i", u, v) / area2
    c[~(area2 > 0) | ~np.isfinite(c)] = 0.0
    edges, inv = np.unique(Es, axis=0, return_inverse=True)
    cot = np.maximum(0.0, np.bincount(inv.ravel(), weights=c, minlength=len(edges)))
    a, b = edges[:, 0], edges[:, 1]
    deg = np.bincount(a, minlength=n) + np.bincount(b, minlength=n)
    cs = np.bincount(a, weights=cot, minlength=n) + np.bincount(b, weights=cot, minlength=n)
    ok = (cs > 0) & np.isfinite(cs)
    degf = np.maximum(deg, 1).astype(float)
    def w(i):
        return np.where(ok[i], (1 - SHARE) / degf[i] + SHARE * cot / np.where(ok[i], cs[i], 1.0), 1.0 / degf[i])
    return a, b, w(a), w(b), deg > 0


def taubin(Vn, F):
    """taubin(P, scale=1): one Taubin step (lambda, mu times scale) of the operator of Vn's positions."""
    a, b, wab, wba, mv = operator(Vn, F)
    n = len(Vn)
    def step(P, f):
        L = np.empty_like(P)
        for k in range(3):
            L[:, k] = np.bincount(a, weights=wab * P[b, k], minlength=n) + np.bincount(b, weights=wba * P[a, k], minlength=n)
        Q = P.copy(); Q[mv] += f * (L[mv] - P[mv]); return Q
    return lambda P, scale=1.0: step(step(P, LAM * scale), MU * scale)


def curves(V, F, Vn, maxT=60):
    step = taubin(Vn, F)
    P = Vn.copy(); t = [normal_error(P, V, F)]; traj = [P]
    for s in range(maxT):
        P = step(P); t.append(normal_error(P, V, F)); traj.append(P)
    return np.array(t), traj


if __name__ == "__main__":
    out = {}
    models = sys.argv[1].split(","); levels = [float(x) for x in sys.argv[2].split(",")]
    seed0 = int(sys.argv[3]); check = "--check" in sys.argv
    for key, V, F, Vn, est in sweep_inputs(models, levels, seed0):
        t, traj = curves(V, F, Vn)
        out[key] = dict(sigma=est.sigma, detail=est.detail, taubin=t.tolist())
        rule = dgmesh.denoising._native.auto_smoothing_steps(est)
        print(f"{key:35s} sig {est.sigma:.3f} det {est.detail:.3f} | best {t.argmin():2d} {t.min():.3f} | rule {rule:2d} {t[rule]:.3f}", flush=True)
        if check:
            for k in (1, 7):
                o = dgmesh.denoising.defaults(); o.automatic = False; o.iterations = 0; o.smoothing_steps = k
                r = dgmesh.denoising._native.denoise_mesh(Vn, F.astype(np.int32), o, None, None)
                print(f"   check {k} steps: numpy {t[k]:.4f} C++ {normal_error(np.asarray(r.vertices), V, F):.4f} "
                      f"max |dP| {np.abs(np.asarray(r.vertices) - traj[k]).max():.2e}", flush=True)
    json.dump(out, open(sys.argv[4], "w"))
