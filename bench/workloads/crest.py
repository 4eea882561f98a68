"""Crest-line workloads (thesis chapter 4): accuracy on the analytic waving surface (table 4.1),
speed of fitting + tracing and of quadric decimation.

    /usr/bin/python3 bench/run.py crest_accuracy crest_speed
"""

import numpy as np

import dgmesh
from bench.common import cgal_mesh, median_time, table

THESIS = {  # table 4.1, one-ring fit, with normals: (L2, Linf)
    (False, "max"): (0.116, 0.415), (False, "min"): (0.141, 0.852),
    (True, "max"): (0.145, 0.479), (True, "min"): (0.126, 0.563),
}


def waving_disc(R, h):
    """z = cos(|xy|) (r(u, v) = (u cos v, u sin v, cos u)) over a disc of radius R, equilateral
    lattice of spacing h."""
    m = int(np.ceil(R / h)) + 2
    J, I = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1), indexing="ij")
    X = I * h + (J & 1) * 0.5 * h
    Y = J * h * np.sqrt(3) / 2
    nx = 2 * m + 1
    j, i = np.meshgrid(np.arange(-m, m), np.arange(-m, m), indexing="ij")
    j, i = j.ravel(), i.ravel()
    idx = lambda jj, ii: (jj + m) * nx + (ii + m)  # noqa: E731
    even = (j & 1) == 0
    t1 = np.where(even[:, None], np.stack([idx(j, i), idx(j, i + 1), idx(j + 1, i)], 1),
                  np.stack([idx(j, i), idx(j, i + 1), idx(j + 1, i + 1)], 1))
    t2 = np.where(even[:, None], np.stack([idx(j, i + 1), idx(j + 1, i + 1), idx(j + 1, i)], 1),
                  np.stack([idx(j, i), idx(j + 1, i + 1), idx(j + 1, i)], 1))
    T = np.concatenate([t1, t2])
    P = np.stack([X.ravel(), Y.ravel()], 1)
    T = T[(np.hypot(P[:, 0], P[:, 1]) <= R)[T].all(1)]
    used = np.unique(T)
    remap = np.full(len(P), -1)
    remap[used] = np.arange(len(used))
    P = P[used]
    V = np.column_stack([P, np.cos(np.hypot(P[:, 0], P[:, 1]))])
    return V, remap[T].astype(np.int32)


def exact(V):
    """Exact meridian / parallel curvatures, meridian e and meridian direction (outward)."""
    rho = np.hypot(V[:, 0], V[:, 1])
    s, c = np.sin(rho), np.cos(rho)
    km = c / (1 + s * s) ** 1.5
    safe = np.where(rho > 1e-12, rho, 1.0)
    kp = np.where(rho > 1e-12, s / (safe * np.sqrt(1 + s * s)), 1.0)
    em = -s * ((1 + s * s) + 3 * c * c) / (1 + s * s) ** 3  # e along the meridian; 0 along parallels
    ur = np.column_stack([V[:, 0] / safe, V[:, 1] / safe, -s])
    ur[rho <= 1e-12] = (1.0, 0.0, 0.0)
    return km, kp, em, ur / np.linalg.norm(ur, axis=1)[:, None]


def e_errors(V, d, mask):
    km, kp, em, ur = exact(V)
    out = {}
    for which in ("max", "min"):
        e, t = d["e_" + which], d["t_" + which]
        meridian = (km >= kp) if which == "max" else (km < kp)
        sgn = np.sign(np.einsum("ij,ij->i", t, ur))
        sgn[sgn == 0] = 1
        err = np.where(meridian, np.abs(e * sgn - em), np.abs(e))[mask]
        out[which] = (float(np.sqrt((err ** 2).mean())), float(err.max()))
    return out


def crest_accuracy(quick):
    R, h = 3.5 * np.pi, 0.42
    V, F = waving_disc(R, h)
    top = dgmesh.topology(V, F)
    bnd = np.zeros(len(V), bool)
    for loop in top["boundary_loops"]:
        bnd[loop] = True
    E = top["edges"]
    ring = bnd.copy()
    ring[E[bnd[E[:, 0]], 1]] = True
    ring[E[bnd[E[:, 1]], 0]] = True
    rows, data = [], {"triangles": int(len(F)), "vertices_measured": int((~ring).sum())}
    for smooth in (False, True):
        for normals in (False, True):
            d = dgmesh.curvature_derivatives(V, F, rings=1, smooth=smooth, use_normals=normals)
            err = e_errors(V, d, ~ring)
            data[f"smooth={smooth},normals={normals}"] = err
            th = THESIS.get((smooth, "max")) if normals else None
            thn = THESIS.get((smooth, "min")) if normals else None
            rows.append([("with" if smooth else "without") + " p->p'", "yes" if normals else "no",
                         err["max"][0], err["max"][1], err["min"][0], err["min"][1],
                         f"{th[0]} / {th[1]}" if th else "0.31 / 0.93", f"{thn[0]} / {thn[1]}" if thn else "0.30 / 0.93"])
    md = ("### Crest lines: accuracy on the waving surface (thesis table 4.1)\n\n"
          f"r(u, v) = (u cos v, u sin v, cos u) for u <= 3.5 pi, equilateral lattice of spacing {h} "
          f"({len(F)} triangles), one-ring fit. Errors of e_max, e_min against the exact values "
          "(orientation aligned with the exact meridian direction), over the vertices outside the "
          "boundary's one-ring (the thesis does not state its domain or mesh).\n\n"
          + table(["smoothing", "normals", "e_max L2", "e_max Linf", "e_min L2", "e_min Linf",
                   "thesis e_max", "thesis e_min"], rows)
          + "\n\n`/usr/bin/python3 bench/run.py crest_accuracy`\n")
    return {"markdown": md, "data": data}


def crest_speed(quick):
    V, F = cgal_mesh("armadillo")
    Vs, Fs = dgmesh._native.subdivide_linear(V, F)  # 208K triangles
    rows, data = [], {}
    for k in ((1,) if quick else (1, 2, 3, 4)):
        t, _ = median_time(lambda: dgmesh.crest_lines(Vs, Fs, rings=k), repeats=3 if quick else 5)
        rows.append([f"crest lines (fit + trace), k = {k}", len(Fs), t])
        data[f"crest_k{k}"] = t
    if not quick:
        V2, F2 = dgmesh._native.subdivide_linear(Vs, Fs)  # 832K
        V3, F3 = dgmesh._native.subdivide_linear(V2, F2)  # 3.3M
        t, _ = median_time(lambda: dgmesh.crest_lines(V3, F3, rings=1), repeats=3)
        rows.append(["crest lines (fit + trace), k = 1", len(F3), t])
        data["crest_k1_3M"] = t
        t, _ = median_time(lambda: dgmesh.decimate(V2, F2, target_faces=100_000), repeats=3)
        rows.append(["decimate to 100K triangles", len(F2), t])
        data["decimate_832K"] = t
    md = ("### Crest lines: speed\n\nArmadillo (CGAL data) linearly subdivided; median wall time "
          "including input validation. Targets: fit + trace on ~200K triangles, k = 1 <= 0.3 s; "
          "decimating 1M -> 100K <= 3 s.\n\n" + table(["task", "triangles", "seconds"], rows)
          + "\n\n`/usr/bin/python3 bench/run.py crest_speed`\n")
    return {"markdown": md, "data": data}


WORKLOADS = {"crest_accuracy": crest_accuracy, "crest_speed": crest_speed}
