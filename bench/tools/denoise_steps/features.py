"""Session 25, third part (bench/notes/denoise.md): per-row quantities of the *noisy input* for the step-rule
rows of sweep_op.py outputs, to test whether a third quantity explains best_steps / rule_steps.
For every row: the estimate (sigma, detail, curvature, outliers, samples, edge_length), the vertex
count, the triangulation (fraction of interior vertices of valence != 6, valence std, edge-length
coefficient of variation, triangle quality), the size (sqrt(area) / e, bbox diagonal / e), the
smoothing operator's tangential pull (tang: median |tangential part of the half-uniform half-cotangent
umbrella| / e; tangrel: its ratio to the whole umbrella), the estimate after 5 and 15 Taubin steps
(s5, d5, s15, d15, in units of the input's e), and the
same for every noise-free CGAL mesh of >= 1000 vertices (the clean constraint).
Usage: features.py SWEEP.json SEED OUT.json  |  features.py --clean OUT.json   (from any directory)."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(pathlib.Path(__file__).parent)]
import numpy as np, dgmesh
from bench.common import cgal_dir


def feats(V, F):
    V = np.asarray(V, float); F = np.asarray(F)
    est = dgmesh.estimate_noise(V, F)
    used = np.unique(F)
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    Eu, cnt = np.unique(E, axis=0, return_counts=True)
    n = len(V)
    deg = np.bincount(Eu.ravel(), minlength=n)
    boundary = np.zeros(n, bool); boundary[Eu[cnt == 1].ravel()] = True
    inner = np.setdiff1d(used, np.where(boundary)[0])
    L = np.linalg.norm(V[Eu[:, 0]] - V[Eu[:, 1]], axis=1)
    e = L.mean()
    a2 = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    l2 = (np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2) ** 2).sum(axis=1)
    quality = 2 * np.sqrt(3) * a2 / np.maximum(l2, 1e-300)  # 1 equilateral, 0 degenerate
    P = V[used]
    # the smoothing operator's own tangential pull (sweep_op.operator: half uniform, half cotangent
    # weights): median |tangential part of (sum w x_j - x_i)| / e and its ratio to the whole
    from sweep_op import operator
    a, b, wab, wba, mv = operator(V, F)
    Lx = np.stack([np.bincount(a, weights=wab * V[b, k], minlength=n) + np.bincount(b, weights=wba * V[a, k], minlength=n)
                   for k in range(3)], axis=1) - V
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    vn = np.stack([np.bincount(F.ravel(), weights=np.repeat(fn[:, k], 3), minlength=n) for k in range(3)], axis=1)
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    Lt = Lx - (Lx * vn).sum(axis=1)[:, None] * vn
    tl = np.linalg.norm(Lt[inner], axis=1); al = np.linalg.norm(Lx[inner], axis=1)
    # a probe: the estimate again after 5 and 15 Taubin steps of the operator (sweep_op.curves' step):
    # how much of the reading the smoothing removes (noise) and how much stays (shape)
    probe = {}
    P = V.copy()
    for s in range(1, 16):
        for f in (0.6, -0.62):
            Lp = np.stack([np.bincount(a, weights=wab * P[b, k], minlength=n) + np.bincount(b, weights=wba * P[a, k], minlength=n)
                           for k in range(3)], axis=1)
            Q = P.copy(); Q[mv] += f * (Lp[mv] - P[mv]); P = Q
        if s in (5, 15):
            ep = dgmesh.estimate_noise(P, F)
            probe.update({f"s{s}": ep.sigma * ep.edge_length / est.edge_length, f"d{s}": ep.detail * ep.edge_length / est.edge_length})
    return dict(**probe, tang=float(np.median(tl) / e), tangrel=float(np.median(tl / np.maximum(al, 1e-300))),
                sigma=est.sigma, detail=est.detail, curv=est.curvature, outl=est.outliers, samples=est.samples,
                e=est.edge_length, nv=int(len(used)), irr=float((deg[inner] != 6).mean()) if len(inner) else 0.0,
                valstd=float(deg[inner].std()) if len(inner) else 0.0, edgecv=float(L.std() / e),
                quality=float(np.median(quality)), size=float(np.sqrt(a2.sum() / 2) / e),
                diag=float(np.linalg.norm(P.max(0) - P.min(0)) / e))


if __name__ == "__main__":
    out = {}
    if sys.argv[1] == "--clean":
        for p in sorted(cgal_dir().glob("*.off")):
            try:
                V, F = dgmesh.read_mesh(p); V = np.asarray(V, float); F = np.asarray(F)
                if len(V) < 1000 or len(F) == 0: continue
                out[p.stem] = feats(V, F)
            except Exception as ex:
                print(p.stem, "skipped:", ex); continue
            print(p.stem, {k: round(v, 3) for k, v in out[p.stem].items()}, flush=True)
        json.dump(out, open(sys.argv[2], "w"), indent=1); sys.exit()
    from rows import sweep_rows
    rows = json.load(open(sys.argv[1]))
    for key, row, Vn, F in sweep_rows(rows, int(sys.argv[2])):
        out[key] = feats(Vn, F)
        assert abs(out[key]["sigma"] - row["sigma"]) < 1e-9, key  # the same noisy mesh as the sweep
        print(key, {k: round(v, 3) for k, v in out[key].items()}, flush=True)
    json.dump(out, open(sys.argv[3], "w"), indent=1)
