"""Session 30 (issue 32): does the spatial correlation of the finest-scale residual tell a scan's own detail
from noise? d_i = N_i . (v_i - mean of its neighbours) / e (uniform umbrella along the area-weighted vertex normal).
White noise gives adjacent vertices a known negative correlation (rho_n, from the stencils: about -0.24 on valence 6);
a smooth shape gives +1. Prints, per model and noise (normal / isotropic, levels in e, seed 11 + 1000 level as
denoise_auto's), the lag-1 correlation over the edges (plain, and a robust one from the MADs of d_a + d_b and
d_a - d_b) and the robust deviation of d.
Usage: lagcorr.py MODELS (as bench/tools/denoise_noise25/multiscale.py's)."""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench/tools/denoise_noise25")]
import numpy as np  # noqa: E402
from multiscale import synthetic  # noqa: E402

from bench.workloads.denoise import add_noise, add_noise_isotropic  # noqa: E402


def edges(F):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return np.unique(np.sort(E, 1), axis=0)


def vertex_normals(V, F):
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    VN = np.zeros_like(V)
    for k in range(3):
        np.add.at(VN, F[:, k], N)
    return VN / np.linalg.norm(VN, axis=1, keepdims=True)


def noise_correlation(E, deg):
    """rho of white noise through the umbrella stencils (two common neighbours per edge)."""
    da, db = deg[E[:, 0]], deg[E[:, 1]]
    cov = -1 / da - 1 / db + 2 / (da * db)
    var = 1 + 1 / deg
    return cov.sum() / ((var[E[:, 0]] + var[E[:, 1]]) / 2).sum()


def lag_stats(V, F, E, deg, e):
    M = np.zeros_like(V)
    np.add.at(M, E[:, 0], V[E[:, 1]])
    np.add.at(M, E[:, 1], V[E[:, 0]])
    d = np.einsum("ij,ij->i", V - M / deg[:, None], vertex_normals(V, F)) / e
    a, b = d[E[:, 0]], d[E[:, 1]]
    rho = np.sum(a * b) / np.sum((a ** 2 + b ** 2) / 2)
    ms, mt = np.median(np.abs(a + b)) ** 2, np.median(np.abs(a - b)) ** 2
    return rho, (ms - mt) / (ms + mt), 1.4826 * np.median(np.abs(d))


if __name__ == "__main__":
    for name in sys.argv[1].split(","):
        V, F = synthetic(name)
        V, F = np.asarray(V, float), np.asarray(F)
        E = edges(F)
        deg = np.bincount(E.ravel(), minlength=len(V)).astype(float)
        e = np.mean(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1))
        row = []
        for kind in ("normal", "isotropic"):
            for lv in (0, 0.05, 0.1, 0.2):
                if lv == 0 and kind == "isotropic":
                    continue
                Vn = V if lv == 0 else (add_noise if kind == "normal" else add_noise_isotropic)(V, F, lv, 11 + int(lv * 1000))
                rho, rho_robust, s = lag_stats(Vn, F, E, deg, e)
                row.append(f"{kind[:3]} {lv}: {rho:+.2f} {rho_robust:+.2f} {s:.3f}")
        print(f"{name:18s} rho_n {noise_correlation(E, deg):+.3f} | " + " | ".join(row), flush=True)
