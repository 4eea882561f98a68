"""Numpy prototype of noise-robust variants of the two-pass jet fit (issue #31), measured on the
crest_derivatives surfaces. Not a bench workload: the numbers go to bench/notes/crest_derivatives.md.

    /usr/bin/python3 bench/tools/crest_noise_proto.py [surface indices, 1-based] [--variants a,b]

Per-vertex least squares in numpy (slow: about a minute per surface and noise level).
"""

import argparse
import math
import os
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, os.environ.get("DGMESH_ADDON", str(ROOT / "addon")))

from bench.workloads import crest as C  # noqa: E402


def max_normals(V, F):
    """Max's vertex normals (face normal weighted by sin / (|e1| |e2|) = cross / (|e1|^2 |e2|^2))."""
    N = np.zeros_like(V)
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        e1, e2 = V[F[:, b]] - V[F[:, a]], V[F[:, c]] - V[F[:, a]]
        w = np.cross(e1, e2) / ((e1 ** 2).sum(1) * (e2 ** 2).sum(1))[:, None]
        np.add.at(N, F[:, a], w)
    return N / np.linalg.norm(N, axis=1)[:, None]


def perp(n):
    a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.6 else (np.array([0, 1.0, 0]) if abs(n[1]) < 0.6 else np.array([0, 0, 1.0]))
    u = a - a.dot(n) * n
    return u / np.linalg.norm(u)


def monomials(x, y, degree, deriv=0):
    """Columns x^a y^b / (a! b!), 1 <= a + b <= degree, by total degree then falling a."""
    cols = []
    for t in range(1, degree + 1):
        for a in range(t, -1, -1):
            b = t - a
            if deriv == 0:
                cols.append(x ** a * y ** b / (math.factorial(a) * math.factorial(b)))
            elif deriv == 1:
                cols.append(x ** (a - 1) * y ** b / (math.factorial(a - 1) * math.factorial(b)) if a > 0 else 0 * x)
            else:
                cols.append(x ** a * y ** (b - 1) / (math.factorial(a) * math.factorial(b - 1)) if b > 0 else 0 * x)
    return np.stack(cols, 1)


def jet(V, i, ring, n, degree, normals=None, sigma_w=None, ridge=0.0, nweight=1.0):
    """Least-squares jet at vertex i over `ring` (vertex first) in units of the mean neighbour
    distance. Returns (coefficients, u, w, scale, rms height residual in scaled units, dof)."""
    u = perp(n)
    w = np.cross(n, u)
    nb = np.array(ring[1:])
    d = V[nb] - V[i]
    dist = np.linalg.norm(d, axis=1)
    scale = len(nb) / dist.sum()
    d = d * scale
    x, y, z = d @ u, d @ w, d @ n
    wt = np.ones(len(nb)) if sigma_w is None else np.exp(-0.5 * (x * x + y * y) / sigma_w ** 2)
    rows, rhs, rw = [monomials(x, y, degree)], [z], [wt]
    if normals is not None:
        m = normals[nb]
        ma, mb, mc = m @ u, m @ w, m @ n
        rows += [monomials(x, y, degree, 1), monomials(x, y, degree, 2)]
        rhs += [-ma / mc, -mb / mc]
        rw += [wt * nweight, wt * nweight]
        e0 = np.zeros((2, rows[0].shape[1]))
        e0[0, 0] = e0[1, 1] = 1.0
        rows.append(e0)
        rhs.append(np.zeros(2))
        rw.append(np.full(2, nweight))
    A = np.vstack(rows)
    b = np.concatenate(rhs)
    sw = np.sqrt(np.concatenate(rw))
    Aw, bw = A * sw[:, None], b * sw
    M = Aw.T @ Aw
    if ridge > 0:
        R = np.zeros(M.shape[0])
        R[5:] = ridge  # cubic and higher coefficients only
        M = M + np.diag(R)
    c = np.linalg.solve(M + 1e-9 * (np.trace(M) + 1) * np.eye(len(M)), Aw.T @ bw)
    res = monomials(x, y, degree) @ c - z
    return c, u, w, scale, float(np.sqrt((res ** 2).mean())), len(nb) - len(c)


def fields(c, u, w, n, scale):
    """k_max, k_min, e_max, e_min, t_max, t_min of the graph at the origin (as write_fields)."""
    hx, hy, hxx, hxy, hyy = c[:5]
    cc = c[5:9] if len(c) >= 9 else np.zeros(4)
    G = math.sqrt(1 + hx * hx + hy * hy)
    nn = np.array([-hx / G, -hy / G, 1 / G])
    e1 = np.array([1.0, 0.0, hx]) / math.sqrt(1 + hx * hx)
    e2 = np.cross(nn, e1)

    def hess(a, q):
        return a[0] * (hxx * q[0] + hxy * q[1]) + a[1] * (hxy * q[0] + hyy * q[1])
    s00, s01, s11 = -hess(e1, e1) / G, -hess(e1, e2) / G, -hess(e2, e2) / G
    mean, dev = 0.5 * (s00 + s11), math.hypot(0.5 * (s00 - s11), s01)
    th = 0.5 * math.atan2(2 * s01, s00 - s11)
    tmax, tmin = math.cos(th) * e1 + math.sin(th) * e2, -math.sin(th) * e1 + math.cos(th) * e2
    kmax, kmin = mean + dev, mean - dev

    def cub(t):
        return cc[0] * t[0] ** 3 + 3 * cc[1] * t[0] ** 2 * t[1] + 3 * cc[2] * t[0] * t[1] ** 2 + cc[3] * t[1] ** 3

    def ext(t, k):
        return (-cub(t) + 3 * k * hess(t, nn)) / G
    B = np.stack([u, w, n], 1)
    return (kmax * scale, kmin * scale, ext(tmax, kmax) * scale ** 2, ext(tmin, kmin) * scale ** 2, B @ tmax, B @ tmin)


class Est:
    def __init__(self, nv):
        self.e_max, self.e_min = np.zeros(nv), np.zeros(nv)
        self.t_max, self.t_min = np.zeros((nv, 3)), np.zeros((nv, 3))


def asymmetry(V, i, ring, n):
    """|mean of the neighbours' tangent offsets| / mean distance: 0 on a centrally symmetric ring."""
    d = V[np.array(ring[1:])] - V[i]
    d = d - np.outer(d @ n, n)
    return float(np.linalg.norm(d.mean(0)) / np.linalg.norm(d, axis=1).mean())


def pass1(V, F, rings2, sigma_w=None, rings_used=None, degree=3, asym=None):
    """Pass-1 normals (cubic on heights of the given rings) and per-vertex height residual
    (scaled units, corrected for the degrees of freedom)."""
    Nm = max_normals(V, F)
    N = Nm.copy()
    res = np.full(len(V), np.nan)
    for i, ring in enumerate(rings2):
        if len(ring) < 14:
            continue
        deg = degree if len(ring) >= 17 else 3
        if asym is not None and len(ring) >= 17:
            deg = 4 if asymmetry(V, i, ring, Nm[i]) > asym else 3
        c, u, w, s, r, dof = jet(V, i, ring, Nm[i], deg, sigma_w=sigma_w)
        g = -c[0] * u - c[1] * w + Nm[i]
        N[i] = g / np.linalg.norm(g)
        if dof > 0:
            res[i] = r * math.sqrt((len(ring) - 1) / dof)
    return N, res


def noise_level(res):
    """Robust global noise estimate: median of the per-vertex residuals."""
    return float(np.nanmedian(res))


def run_variant(name, V, F, R, mask, N1, res1, k):
    est = Est(len(V))
    sig = noise_level(res1)
    for i in np.nonzero(mask)[0]:
        n = N1[i]
        if name == "jet":
            c, u, w, s, _, _ = jet(V, i, R[k][i], n, 3 if k == 1 else 5, normals=N1)
        elif name.startswith("ridge"):  # ridge on cubic+ coefficients, lambda = f * (sigma / truncation)^2
            f = float(name[5:])
            lam = f * sig ** 2 * 1e4
            c, u, w, s, _, _ = jet(V, i, R[k][i], n, 3 if k == 1 else 5, normals=N1, ridge=lam)
        elif name.startswith("nw"):  # normal rows down-weighted as noise grows
            f = float(name[2:])
            c, u, w, s, _, _ = jet(V, i, R[k][i], n, 3 if k == 1 else 5, normals=N1, nweight=1 / (1 + f * sig ** 2 * 1e4))
        elif name == "q1":  # quartic on the k-ring (heights + pass-1 normals) when it has the equations
            nb = len(R[k][i]) - 1
            c, u, w, s, _, _ = jet(V, i, R[k][i], n, 4 if (k == 1 and 3 * nb + 2 >= 18) else (3 if k == 1 else 5), normals=N1)
        elif name.startswith("lowval"):  # 1-ring fit widened to the 2-ring (degree 3 / 5) where the 1-ring has < 6 vertices
            nb = len(R[k][i]) - 1
            deg = int(name[6:] or 5)
            if k == 1 and nb < 6:
                c, u, w, s, _, _ = jet(V, i, R[2][i], n, deg, normals=N1)
            else:
                c, u, w, s, _, _ = jet(V, i, R[k][i], n, 3 if k == 1 else 5, normals=N1)
        elif name == "g1":  # the 1-ring cubic with the 2-ring's heights, Gaussian-weighted (sigma_w = 1)
            c, u, w, s, _, _ = jet(V, i, R[k + 1][i], n, 3 if k == 1 else 5, normals=N1, sigma_w=0.75 if k == 1 else 1.5)
        elif name == "wideall":  # the "wide" fit whatever the noise
            c, u, w, s, _, _ = jet(V, i, R[min(k + 1, 3)][i], n, 3, normals=N1, sigma_w=k + 0.5)
        elif name.startswith("wide"):  # under noise: degree 3, Gaussian weights over k+1 rings, heights + normals
            kk = min(k + 1, 3) if sig > 0.01 else k
            c, u, w, s, _, _ = jet(V, i, R[kk][i], n, 3 if (k == 1 or sig > 0.01) else 5, normals=N1,
                                   sigma_w=(k + 0.5) if sig > 0.01 else None)
        else:
            raise ValueError(name)
        km, kn, em, en, tm, tn = fields(c, u, w, n, s)
        est.e_max[i], est.e_min[i], est.t_max[i], est.t_min[i] = em, en, tm, tn
    return est


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("surfaces", nargs="*", type=int)
    ap.add_argument("--variants", default="jet")
    ap.add_argument("--noise", default="0,0.05,0.1")
    ap.add_argument("--rings", default="1,2")
    ap.add_argument("--pass1", default="2")  # rings of pass 1; "3g": 3-ring, Gaussian weights
    args = ap.parse_args()
    surfaces = C.derivative_surfaces()
    pick = args.surfaces or range(1, len(surfaces) + 1)
    for si in pick:
        name, (V0, F), flds = surfaces[si - 1]
        mask = C._measured(V0, F, flds)
        for sigma in [float(s) for s in args.noise.split(",")]:
            V = V0 if sigma == 0 else C._noisy(V0, F, sigma, 100 + si - 1)
            R = {k: C._rings(V, F, k) for k in (1, 2, 3)}
            if args.pass1 == "2":
                N1, res1 = pass1(V, F, R[2])
            elif args.pass1.startswith("2a"):
                a = float(args.pass1[2:])
                print("asym quantiles", np.quantile([asymmetry(V, i, R[2][i], max_normals(V, F)[i]) for i in range(0, len(V), 7)], [0.1, 0.5, 0.9]))
                N1, res1 = pass1(V, F, R[2], asym=a)
            elif args.pass1 == "2q":
                N1, res1 = pass1(V, F, R[2], degree=4)
            else:
                N1, res1 = pass1(V, F, R[3], sigma_w=1.5)
            line = [f"({si}) noise {sigma:g} sigma_hat {noise_level(res1):.4f}"]
            for k in [int(r) for r in args.rings.split(",")]:
                for var in args.variants.split(","):
                    est = run_variant(var, V, F, R, mask, N1, res1, k)
                    em, en = C._errors(est, flds, mask)
                    line.append(f"{var} k={k}: {em:.4f} / {en:.4f}")
            print(" | ".join(line), flush=True)


if __name__ == "__main__":
    main()
