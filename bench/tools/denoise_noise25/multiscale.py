"""Session 25 (bench/notes/denoise.md): leverage-standardised residuals of local polynomial fits at several
widths, on noise-free and noisy meshes, to see whether the residual's growth with the width separates shape
from noise. numpy re-implementation of noise_estimate.cpp's fit (PCA frame of the k nearest points, the
centre at the origin, least squares, z = -c0 / sqrt(1 - h)); degree 2 or 3.
Usage: multiscale.py MODELS LEVELS SEED OUT.json   (MODELS: CGAL stems or icosphere, torus, graph, superellipsoid)
For each mesh / noise kind / level: robust sigma (1.4826 median |z|) and the median mean-square radius of the
fit (in e) for every degree and width."""
import sys, json, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools" / "denoise_steps")]
import numpy as np
from dgmesh import shapes
from bench.common import cgal_mesh
from bench.workloads.denoise import add_noise, add_noise_isotropic, edge_length

WIDTHS = (12, 16, 19, 27, 36, 48)


def synthetic(name):
    if name == "icosphere":
        return shapes.icosphere(4, 1.0)
    if name == "torus":
        return shapes.torus(1.0, 0.35, 96, 40)
    if name == "graph":
        V, F = shapes.grid(40, 40); V = V.copy()
        V[:, 2] = 0.3 * np.sin(2 * V[:, 0]) * np.cos(3 * V[:, 1]); return V, F
    if name.startswith("superellipsoid"):  # tests/python/test_denoise.py's clean coarse shape (x^8 + y^8 + z^8 = 1)
        V, F = shapes.icosphere(2, 1.0); V = np.asarray(V, float)
        V = V / (np.sum(V ** 8, axis=1) ** (1 / 8))[:, None]
        return V, F
    return cgal_mesh(name)


def knn(P, k, block=1024):
    out = np.empty((len(P), k), dtype=np.int64)
    sq = np.einsum("ij,ij->i", P, P)
    for s in range(0, len(P), block):
        d = sq[s:s + block, None] - 2 * P[s:s + block] @ P.T + sq[None, :]
        d[np.arange(len(d)), np.arange(s, s + len(d))] = -1.0  # the centre first
        idx = np.argpartition(d, k - 1, axis=1)[:, :k]
        dd = np.take_along_axis(d, idx, 1)
        out[s:s + block] = np.take_along_axis(idx, np.argsort(dd, axis=1), 1)
    return out


def residuals(P, nb, k, deg, e):
    """Standardised residuals z (n,) and mean-square radius of each fit (n,), in e units."""
    Q = (P[nb[:, :k]] - P[:, None, :]) / e  # (n, k, 3), centre at 0
    C = Q - Q.mean(axis=1, keepdims=True)
    w, U = np.linalg.eigh(np.einsum("nki,nkj->nij", C, C))
    n, t1, t2 = U[:, :, 0], U[:, :, 2], U[:, :, 1]
    u = np.einsum("nki,ni->nk", Q, t1); v = np.einsum("nki,ni->nk", Q, t2); h = np.einsum("nki,ni->nk", Q, n)
    cols = [np.ones_like(u), u, v, u * u, u * v, v * v]
    if deg == 3:
        cols += [u ** 3, u * u * v, u * v * v, v ** 3]
    X = np.stack(cols, axis=2)  # (n, k, m)
    A = np.einsum("nki,nkj->nij", X, X); b = np.einsum("nki,nk->ni", X, h)
    ok = np.linalg.cond(A) < 1e12
    A[~ok] = np.eye(A.shape[1])
    c = np.linalg.solve(A, b[..., None])[..., 0]
    e0 = np.zeros(A.shape[1]); e0[0] = 1
    lev = np.linalg.solve(A, np.broadcast_to(e0, b.shape)[..., None])[..., 0][:, 0]
    ok &= (lev > 0) & (lev < 1 - 1e-3)
    z = np.where(ok, -c[:, 0] / np.sqrt(np.clip(1 - lev, 1e-3, None)), np.nan)
    return z, (u * u + v * v).mean(axis=1)


def measure(Vn, F, degs=(2, 3)):
    used = np.unique(F)
    P = Vn[used]; e = edge_length(Vn, F)
    nb = knn(P, max(WIDTHS))
    r = {}
    for deg in degs:
        for k in WIDTHS:
            if deg == 2 and k > 36 and False:
                continue
            z, rho2 = residuals(P, nb, k, deg, e)
            r[f"d{deg}k{k}"] = dict(sigma=1.482602218 * float(np.nanmedian(np.abs(z))), rho2=float(np.median(rho2)))
    return r


if __name__ == "__main__":
    models = sys.argv[1].split(","); levels = [float(x) for x in sys.argv[2].split(",")]
    seed0 = int(sys.argv[3]); out = {}
    for name in models:
        V, F = synthetic(name); V = np.asarray(V, float); F = np.asarray(F)
        for kind in ("normal", "isotropic"):
            for lv in levels:
                if lv == 0 and kind == "isotropic":
                    continue
                Vn = V if lv == 0 else (add_noise if kind == "normal" else add_noise_isotropic)(V, F, lv, seed0 + int(lv * 1000))
                key = f"{name} {kind} {lv}"
                out[key] = measure(Vn, F)
                print(key, " ".join(f"{k}:{v['sigma']:.3f}" for k, v in out[key].items() if k.startswith("d3") or k in ("d2k12", "d2k19", "d2k36")), flush=True)
    json.dump(out, open(sys.argv[4], "w"), indent=0)
