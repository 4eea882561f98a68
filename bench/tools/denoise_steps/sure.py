"""Session 27 (bench/notes/denoise.md): can the Taubin step count be chosen by a risk estimate instead of
the rule of auto_smoothing_steps? Per row (the noisy meshes of sweep.py, seed SEED + 1000 level (default 11), and the
noise-free mesh) the half-uniform half-cotangent Taubin operator of sweep_op.py runs 0-60 steps (the rule's cap), and
the count is chosen by:
  best      the normal error against the clean mesh (the oracle);
  rule      auto_smoothing_steps of the noisy mesh's estimate (the library's default);
  risk      the oracle's normal-direction position risk sum ((P_k - V) . N_clean)^2;
  SURE      Stein's unbiased risk estimate of that risk for a linear smoother S_k = S^k,
                sum ((Vn - P_k) . N_k)^2 - n s^2 + 2 s^2 tr(S_k)
            with N_k the normals of P_k, tr(S_k) by Hutchinson's estimator (8 Rademacher probes), and s
            the true noise deviation (SURE true), the estimate's sigma (SURE est), or the noise the
            step rule counts, sqrt(max(0, sigma^2 - min(0.9 detail, 0.1)^2)) (SURE floor);
  GCV       generalised cross-validation of the same normal residual, sum(...) / (1 - tr(S_k) / n)^2,
            k >= 1 (it needs no s).
Usage: sure.py MODELS OUT.json [SEED] (from bench/tools/denoise_steps), or sure.py --summary OUT.json."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from bench.common import cgal_mesh
from bench.workloads.denoise import normal_error, edge_length
from rows import noisy
from sweep_op import operator, LAM, MU

STEPS, PROBES = 60, 8


def vertex_normals(P, F):
    return np.asarray(dgmesh.curvature(P, F).normals)


def floored(est):
    """The noise the step rule counts (denoise.h auto_options): sigma above the shape floor min(0.9 d, 0.1)."""
    return float(np.sqrt(max(0.0, est.sigma**2 - min(0.9 * max(est.detail, 0.03), 0.1) ** 2)))


def taubin_run(Vn, F):
    """(positions after 0..STEPS steps, Hutchinson estimates of tr(S^k))."""
    a, b, wab, wba, mv = operator(Vn, F)
    n = len(Vn)

    def step(P, f):
        L = np.stack([np.bincount(a, weights=wab * P[b, k], minlength=n) + np.bincount(b, weights=wba * P[a, k], minlength=n)
                      for k in range(P.shape[1])], axis=1)
        Q = P.copy(); Q[mv] += f * (L[mv] - P[mv]); return Q

    Z = np.random.default_rng(0).choice([-1.0, 1.0], size=(n, PROBES))
    P, Y, traj, tr = Vn.copy(), Z.copy(), [Vn.copy()], [float(n)]
    for _ in range(STEPS):
        P, Y = step(step(P, LAM), MU), step(step(Y, LAM), MU)
        traj.append(P); tr.append(float((Z * Y).sum() / PROBES))
    return traj, np.array(tr)


def main(models, out_path, seed0=11):
    out = {}
    print(f"{'row':34s} {'best':>10s} {'rule':>10s} {'risk':>10s} {'SURE true':>10s} {'SURE est':>10s} {'SURE floor':>10s} {'GCV':>10s}  (steps error)")
    for name in models:
        V, F = cgal_mesh(name); V, F = np.asarray(V, float), np.asarray(F)
        e, NV = edge_length(V, F), vertex_normals(V, F)
        for kind in ("normal", "isotropic"):
            for level in (0.0, 0.05, 0.1, 0.2, 0.3):
                if level == 0 and kind == "isotropic":
                    continue
                Vn = noisy(V, F, kind, level, seed0) if level > 0 else V.copy()
                est = dgmesh.estimate_noise(Vn, F)
                traj, tr = taubin_run(Vn, F)
                n = len(Vn)
                err = np.array([normal_error(P, V, F) for P in traj])
                risk = np.array([(((P - V) * NV).sum(1) ** 2).sum() for P in traj])
                rss = np.array([(((Vn - P) * vertex_normals(P, F)).sum(1) ** 2).sum() for P in traj])
                sure = lambda s: rss - n * (s * e) ** 2 + 2 * (s * e) ** 2 * tr
                gcv = rss[1:] / (1 - tr[1:] / n) ** 2
                picks = dict(best=int(err.argmin()), rule=int(dgmesh.denoising._native.auto_smoothing_steps(est)),
                             risk=int(risk.argmin()), sure_true=int(sure(level).argmin()),
                             sure_est=int(sure(est.sigma).argmin()), sure_floor=int(sure(floored(est)).argmin()),
                             gcv=int(1 + gcv.argmin()))
                key = f"{name} {kind} {level}"
                out[key] = dict(picks=picks, err=err.tolist(), sigma=est.sigma, detail=est.detail, n=n, e=e,
                                rss=rss.tolist(), trace=tr.tolist())
                print(f"{key:34s}" + "".join(f" {k:3d} {err[k]:6.2f}" for k in picks.values()), flush=True)
    json.dump(out, open(out_path, "w"))
    summary(out)


def summary(out):
    """Per selector: mean excess of its normal error over the best count's on the noisy rows (the mean of
    err / best - 1), rows within 2 % of the best, and the largest error it leaves on a noise-free row."""
    noisy_rows = [r for k, r in out.items() if not k.endswith(" 0.0")]
    clean_rows = [r for k, r in out.items() if k.endswith(" 0.0")]
    print(f"{len(noisy_rows)} noisy rows, {len(clean_rows)} noise-free")
    for sel in noisy_rows[0]["picks"]:
        ex = np.array([r["err"][r["picks"][sel]] / min(r["err"]) - 1 for r in noisy_rows])
        worst_clean = max((r["err"][r["picks"][sel]] for r in clean_rows), default=0.0)
        print(f"  {sel:10s} mean excess {100 * ex.mean():6.2f} %, within 2 %: {(ex <= 0.02).sum():3d}, "
              f"noise-free worst {worst_clean:.2f} degrees")


if __name__ == "__main__":
    if sys.argv[1] == "--summary":
        summary(json.load(open(sys.argv[2])))
    else:
        main(sys.argv[1].split(","), sys.argv[2], *(int(a) for a in sys.argv[3:4]))
