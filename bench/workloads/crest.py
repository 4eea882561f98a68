"""Crest-line workloads (thesis chapter 4): accuracy on the analytic waving surface (table 4.1),
triangulation independence (fig. 4.7), speed of fitting + tracing and of quadric decimation, and
renders of crest lines, feature-sensitive decimation and segmentation (figs. 4.1-4.2, 4.19, 4.26).

    /usr/bin/python3 bench/run.py crest_accuracy crest_independence crest_speed crest_renders
"""

import json
import os
import resource
import pathlib
import subprocess
import tempfile
import time

import numpy as np

import dgmesh
from bench.common import IMAGES, cgal_mesh, cgal_tool, loop_subdivide, median_time, run_blender, shapes, table

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
        e, t = getattr(d, "e_" + which), getattr(d, "t_" + which)
        meridian = (km >= kp) if which == "max" else (km < kp)
        sgn = np.sign(np.einsum("ij,ij->i", t, ur))
        sgn[sgn == 0] = 1
        err = np.where(meridian, np.abs(e * sgn - em), np.abs(e))[mask]
        out[which] = (float(np.sqrt((err ** 2).mean())), float(err.max()))
    return out


def _waving_on(P, T):
    """Lattice points P (n, 2) and triangles T lifted onto z = cos(|xy|), unused points dropped."""
    used = np.unique(T)
    remap = np.full(len(P), -1)
    remap[used] = np.arange(len(used))
    P = P[used]
    return np.column_stack([P, np.cos(np.hypot(P[:, 0], P[:, 1]))]), remap[T].astype(np.int32)


def _jittered_waving(R, h, jitter, seed):
    """Equilateral lattice of spacing h with every point moved by up to `jitter` h in x and y."""
    V, T = waving_disc(1.2 * R, h)
    P = V[:, :2] + np.random.default_rng(seed).uniform(-jitter * h, jitter * h, (len(V), 2))
    return _waving_on(P, T[(np.hypot(P[:, 0], P[:, 1]) <= R)[T].all(1)])


def _union_jack_waving(R, h):
    V, F = union_jack(R, h)  # lifted onto the bumpy test surface: re-lift onto the waving one
    return _waving_on(V[:, :2], F)


def accuracy_meshes():
    """Meshes of the waving surface under 5K triangles (the thesis does not give its mesh). The
    surface is rotationally symmetric, so a rotated lattice gives the same errors: the meshes vary
    the spacing, the connectivity and the regularity instead."""
    return [
        ("equilateral, h = 0.42, rho <= 3.5 pi", waving_disc(3.5 * np.pi, 0.42)),
        ("equilateral, h = 0.34, rho <= 2.8 pi", waving_disc(2.8 * np.pi, 0.34)),
        ("equilateral, h = 0.30, rho <= 2.5 pi", waving_disc(2.5 * np.pi, 0.30)),
        ("square grid, alternating diagonals, h = 0.34, rho <= 2.8 pi", _union_jack_waving(2.8 * np.pi, 0.34)),
        ("equilateral h = 0.42 jittered by 20% (seed 1), rho <= 3.5 pi", _jittered_waving(3.5 * np.pi, 0.42, 0.2, 1)),
        ("equilateral h = 0.34 jittered by 20% (seed 2), rho <= 2.8 pi", _jittered_waving(2.8 * np.pi, 0.34, 0.2, 2)),
    ]


def _interior(V, F):
    """Vertices outside the boundary's one-ring (one-sided fits there)."""
    top = dgmesh.topology(V, F)
    bnd = np.zeros(len(V), bool)
    for loop in top.boundary_loops:
        bnd[loop] = True
    E = top.edges
    ring = bnd.copy()
    ring[E[bnd[E[:, 0]], 1]] = True
    ring[E[bnd[E[:, 1]], 0]] = True
    return ~ring


FITS = [  # (label, smooth, normals, refined); refined = fitted tangent plane + evaluation at p
    ("without p->p', no normals", False, False, False),
    ("without p->p', normals, eq. 4.7 as printed", False, True, False),
    ("without p->p', normals, tangent plane fitted", False, True, True),
    ("with p->p', no normals", True, False, False),
    ("with p->p', normals, eq. 4.7 as printed", True, True, False),
    ("with p->p', normals, tangent plane fitted + transported to p (thesis fit's defaults, jet=False)", True, True, True),
    ("two-pass jet fit (the default, jet=True; bench crest_derivatives)", False, True, True),
]
JET_FIT = FITS[-1][0]


def _thesis_cell(smooth, normals):
    if not normals:
        return "0.31 / 0.93", "0.30 / 0.93"
    th, thn = THESIS[(smooth, "max")], THESIS[(smooth, "min")]
    return f"{th[0]} / {th[1]}", f"{thn[0]} / {thn[1]}"


def crest_accuracy(quick):
    meshes = accuracy_meshes()
    errs = {}  # fit label -> (n_meshes, 4): e_max L2, Linf, e_min L2, Linf
    data = {"meshes": {}}
    for name, (V, F) in meshes:
        mask = _interior(V, F)
        data["meshes"][name] = {"triangles": int(len(F)), "vertices_measured": int(mask.sum())}
        for label, smooth, normals, refined in FITS:
            d = dgmesh.curvature_derivatives(V, F, rings=1, smooth=smooth, use_normals=normals,
                                             fit_tangent_plane=refined, transport_to_vertex=refined,
                                             jet=False) if label != JET_FIT else dgmesh.curvature_derivatives(V, F, jet=True)
            e = e_errors(V, d, mask)
            errs.setdefault(label, []).append([e["max"][0], e["max"][1], e["min"][0], e["min"][1]])
            data["meshes"][name][label] = e
    rows = []
    for label, smooth, normals, _ in FITS:
        a = np.array(errs[label])
        mean, worst = a.mean(0), a.max(0)
        data[label] = {"mean": mean.tolist(), "worst": worst.tolist()}
        thesis = ("-", "-") if label == JET_FIT else _thesis_cell(smooth, normals)
        rows.append([label] + [f"{m:.3f} / {w:.3f}" for m, w in zip(mean, worst)] + list(thesis))
    default = FITS[-1][0]
    printed = FITS[-3][0]
    mesh_rows = [[name, len(F)] + [f"{x:.3f}" for x in errs[default][i]] + [f"{x:.3f}" for x in errs[printed][i]]
                 for i, (name, (V, F)) in enumerate(meshes)]
    md = ("### Crest lines: accuracy on the waving surface (thesis table 4.1)\n\n"
          "r(u, v) = (u cos v, u sin v, cos u) meshed six ways under 5K triangles (the thesis does not give "
          "its mesh): three equilateral lattices of different spacing, a square grid with alternating "
          "diagonals (valences 4 and 8), and two equilateral lattices with every vertex moved sideways by "
          "up to 20% of the spacing (seeded). One-ring fits. L2 and Linf errors of e_max, e_min against the "
          "exact values (direction aligned with the exact meridian direction) over the vertices outside "
          "the boundary's one-ring. Each cell: mean over the six meshes / worst mesh.\n\n"
          "'eq. 4.7 as printed' pins the cubic's gradient to zero at p' (the Max normal of p' is taken as "
          "exact). The thesis fit's defaults fit the tangent plane too (linear terms, the Max normal of p' as one more "
          "normal equation; only at vertices with at least five neighbours, the valence-4 vertices of the "
          "square grid keep eq. 4.7) and evaluates the fitted graph with its exact curvature formulas at the foot "
          "of the original vertex p instead of at p' (eq. 4.9 with a non-zero gradient). The last row is the two-pass jet fit "
          "(the default since issue #31; bench crest_derivatives).\n\n"
          + table(["fit", "e_max L2", "e_max Linf", "e_min L2", "e_min Linf", "thesis e_max", "thesis e_min"], rows)
          + "\n\nPer mesh: the jet fit (jet=True; e_max L2, Linf, e_min L2, Linf), then eq. 4.7 "
          "as printed with p->p' and normals.\n\n"
          + table(["mesh", "triangles", "e_max L2", "e_max Linf", "e_min L2", "e_min Linf",
                   "printed e_max L2", "Linf", "printed e_min L2", "Linf"], mesh_rows)
          + "\n\n`/usr/bin/python3 bench/run.py crest_accuracy`\n")
    return {"markdown": md, "data": data}


def _qem_total(V, F, V2, vmap):
    """The quadric error both decimation modes minimise: area-weighted squared distances of the
    output positions of each input face's corners to that face's plane."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    area2 = np.linalg.norm(n, axis=1)
    n = n / np.maximum(area2, 1e-300)[:, None]
    d = -(n * V[F[:, 0]]).sum(1)
    err = sum(((n * V2[vmap[F[:, k]]]).sum(1) + d) ** 2 for k in range(3))
    return float((0.5 * area2 * err).sum() / 3)


def _cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _timed(fn, repeats):
    """Median wall time and the process CPU time (all threads) of that same run."""
    runs = []
    for _ in range(repeats):
        c0 = _cpu_seconds()
        t, _ = median_time(fn, repeats=1, warmup=0)
        runs.append((t, _cpu_seconds() - c0))
    runs.sort()
    return runs[len(runs) // 2]


def crest_speed(quick):
    load = os.getloadavg()[0]
    V, F = cgal_mesh("armadillo")
    Vs, Fs = dgmesh._native.subdivide_linear(V, F)  # 208K triangles
    rows, data = [], {}
    d = dgmesh.curvature_derivatives(Vs, Fs, rings=1)
    data["jet_noise_ratio"] = (float(d.noise_ratio), bool(d.jet_used))
    fit_used = "jet fit" if d.jet_used else "its noise test picks the thesis fit"
    for k in ((1,) if quick else (1, 2, 3, 4)):
        dgmesh.crest_lines(Vs, Fs, rings=k, threshold=0.0)  # warm-up
        t, c = _timed(lambda: dgmesh.crest_lines(Vs, Fs, rings=k, threshold=0.0), repeats=3 if quick else 5)
        rows.append([f"crest lines (fit + trace), k = {k}, default ({fit_used})", len(Fs), t, c])
        data[f"crest_k{k}"] = t
    for k in (1, 2):  # the jet fit itself, as on a mesh it does not find noisy
        t, c = _timed(lambda: dgmesh.crest_lines(Vs, Fs, rings=k, threshold=0.0, noise_adaptive=False), repeats=3)
        rows.append([f"crest lines (fit + trace), k = {k}, jet fit (noise_adaptive=False)", len(Fs), t, c])
        data[f"crest_k{k}_jet"] = t
    t, c = _timed(lambda: dgmesh.crest_lines(Vs, Fs, rings=1, threshold=0.0, jet=False), repeats=3)
    rows.append(["crest lines (fit + trace), k = 1, thesis fit (jet=False)", len(Fs), t, c])
    data["crest_k1_thesis"] = t
    # A smooth mesh of the same size, where the default uses the jet fit.
    Vl, Fl = loop_subdivide(V, F, 1)
    dl = dgmesh.curvature_derivatives(Vl, Fl, rings=1)
    data["loop_noise_ratio"] = (float(dl.noise_ratio), bool(dl.jet_used))
    t, c = _timed(lambda: dgmesh.crest_lines(Vl, Fl, rings=1, threshold=0.0), repeats=3)
    rows.append([f"Loop-subdivided: crest lines (fit + trace), k = 1, default "
                 f"({'jet fit' if dl.jet_used else 'thesis fit'})", len(Fl), t, c])
    data["crest_k1_loop"] = t
    exe = cgal_tool("cgal_ridges.cpp", "CGAL/Ridges.h")
    if exe is not None:
        for tag, (Vc, Fc) in (("", (Vs, Fs)), ("_loop", (Vl, Fl))):
            with tempfile.TemporaryDirectory() as tmp:
                off = pathlib.Path(tmp) / "m.off"
                dgmesh.write_mesh(off, Vc, Fc)
                out = subprocess.run([str(exe), str(off)], check=True, capture_output=True, text=True).stdout.split()
            fit_s, ridge_s = float(out[0]), float(out[1])
            rows.append([("Loop-subdivided: " if tag else "") + "CGAL Ridges_3 example pipeline (jet fitting d = 3 + "
                         "compute_crest_ridges), 1 thread", len(Fc), fit_s + ridge_s, fit_s + ridge_s])
            data["cgal_ridges" + tag] = {"fit": fit_s, "ridges": ridge_s, "lines": int(out[2])}
        cgal = data["cgal_ridges"]["fit"] + data["cgal_ridges"]["ridges"]
        data["cgal_ridges_over_ours_k1"] = cgal / data["crest_k1"]
        data["cgal_ridges_over_ours_k2"] = cgal / data["crest_k2"] if "crest_k2" in data else None
        data["cgal_ridges_over_jet_k1"] = cgal / data["crest_k1_jet"]
        data["cgal_ridges_over_ours_k1_loop"] = (
            (data["cgal_ridges_loop"]["fit"] + data["cgal_ridges_loop"]["ridges"]) / data["crest_k1_loop"])
    if not quick:
        V2, F2 = dgmesh._native.subdivide_linear(Vs, Fs)  # 832K
        V3, F3 = dgmesh._native.subdivide_linear(V2, F2)  # 3.3M
        t, c = _timed(lambda: dgmesh.crest_lines(V2, F2, rings=1, threshold=0.0), repeats=3)
        rows.append(["crest lines (fit + trace), k = 1", len(F2), t, c])
        data["crest_k1_832K"] = t
        t, c = _timed(lambda: dgmesh.crest_lines(V3, F3, rings=1, threshold=0.0), repeats=3)
        rows.append(["crest lines (fit + trace), k = 1", len(F3), t, c])
        data["crest_k1_3M"] = t
    Vb, Fb = loop_subdivide(*cgal_mesh("bunny00"), 2)  # 1.2M triangles
    t, c = _timed(lambda: dgmesh.decimate(Vb, Fb, target_faces=100_000, feature_weight=0.0), repeats=1 if quick else 3)
    rows.append(["decimate to 100K triangles (eta = 0)", len(Fb), t, c])
    data["decimate_1.2M_to_100K"] = t
    if not quick:
        t, c = _timed(lambda: dgmesh.decimate(Vb, Fb, target_faces=100_000, feature_weight=0.0, greedy=True), repeats=1)
        rows.append(["decimate to 100K triangles (eta = 0, greedy=True: one global queue)", len(Fb), t, c])
        data["decimate_1.2M_to_100K_greedy"] = t
    if not quick:
        lines = dgmesh.crest_lines(Vb, Fb, rings=1, threshold=10.0)
        t, c = _timed(lambda: dgmesh.decimate(Vb, Fb, target_faces=100_000, feature_weight=6.0,
                                              crest_lines=lines), repeats=3)
        rows.append(["decimate to 100K triangles (eta = 6, lines given)", len(Fb), t, c])
        data["decimate_1.2M_to_100K_eta6"] = t
    quality = ""
    if not quick:
        qrows = []
        for model in ("bunny00", "armadillo", "fandisk"):
            V, F = cgal_mesh(model)
            errs = []
            for greedy in (False, True):
                V2, F2, vm = dgmesh.decimate(V, F, target_faces=len(F) // 10, feature_weight=0.0, greedy=greedy,
                                              return_map=True)
                errs.append(_qem_total(V, F, V2, vm))
            qrows.append([model, len(F), len(F) // 10, errs[0] / errs[1]])
            data[f"qem_ratio_{model}"] = errs[0] / errs[1]
        quality = ("\n\nQuality of the default multiple-choice passes against the exact greedy queue: total "
                   "quadric error (area-weighted squared distances of each input face's corners, at their "
                   "output positions, to the face's plane), decimating by 90%.\n\n"
                   + table(["model", "triangles", "target", "QEM passes / QEM greedy"], qrows))
    md = ("### Crest lines: speed\n\nCrest lines: armadillo (CGAL data) linearly subdivided (piecewise flat), and "
          "Loop-subdivided once (smooth); decimation: "
          "bunny00 Loop-subdivided twice. Median wall time including input validation, "
          f"{dgmesh.num_threads()} threads, load average {load:.1f} when the run started (other jobs "
          "share the machine). Targets: fit + trace on ~200K triangles, k = 1 <= 0.3 s; "
          "decimating 1M -> 100K <= 3 s; crest lines >= 10x faster than CGAL's Ridges_3 pipeline (its "
          "example: Monge_via_jet_fitting per vertex, then compute_crest_ridges; bench/tools/cgal_ridges.cpp, "
          "one thread, time measured inside the tool without reading the file). CPU seconds are the "
          "process's user + system time over all "
          "threads for the same run (less sensitive to the machine's load than wall time).\n\n"
          + table(["task", "triangles", "wall seconds", "CPU seconds"], rows)
          + (f"\n\nThe default fit is the jet fit with its noise test: on the linearly subdivided mesh the test "
             f"gives {data['jet_noise_ratio'][0]:.2f} (threshold {dgmesh.crest.JET_NOISE_RATIO:g}), on the "
             f"Loop-subdivided one {data['loop_noise_ratio'][0]:.2f}; the rows with noise_adaptive=False time the jet "
             "fit itself." if "jet_noise_ratio" in data else "")
          + (f" CGAL's Ridges_3 over ours: {data['cgal_ridges_over_ours_k1']:.1f}x (default, k = 1), "
             f"{data['cgal_ridges_over_jet_k1']:.1f}x (jet fit, k = 1), {data['cgal_ridges_over_ours_k1_loop']:.1f}x "
             "(Loop-subdivided, default)." if "cgal_ridges_over_jet_k1" in data else "") + quality
          + "\n\n`/usr/bin/python3 bench/run.py crest_speed`\n")
    return {"markdown": md, "data": data}


# --- triangulation independence (thesis fig. 4.7) ------------------------------------------------

def bumpy(P):
    """The smooth test surface z = f(x, y): elliptic waves plus a tilted bump."""
    x, y = P[:, 0], P[:, 1]
    return 0.8 * np.cos(np.hypot(x, 1.5 * y)) + 0.6 * np.exp(-((x - 2.0) ** 2 + (y + 1.0) ** 2) / 2.0)


def _compact(P, T, keep_vertex):
    T = T[keep_vertex[T].all(1)]
    used = np.unique(T)
    remap = np.full(len(P), -1)
    remap[used] = np.arange(len(used))
    P = P[used]
    return np.column_stack([P, bumpy(P)]), remap[T].astype(np.int32)


def union_jack(R, h):
    """Square grid of spacing h with alternating diagonals (valences 4 and 8), clipped to a disc."""
    n = int(np.ceil(R / h)) + 1
    xs = np.arange(-n, n + 1) * h
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    P = np.column_stack([X.ravel(), Y.ravel()])
    m = 2 * n + 1
    I, J = np.meshgrid(np.arange(2 * n), np.arange(2 * n), indexing="ij")
    I, J = I.ravel(), J.ravel()
    a, b, c, d = I * m + J, (I + 1) * m + J, (I + 1) * m + J + 1, I * m + J + 1
    flip = ((I + J) & 1) == 0
    T = np.concatenate([np.where(flip[:, None], np.stack([a, b, c], 1), np.stack([a, b, d], 1)),
                        np.where(flip[:, None], np.stack([a, c, d], 1), np.stack([b, c, d], 1))])
    return _compact(P, T, np.hypot(P[:, 0], P[:, 1]) <= R)


def jittered_lattice(R, h, angle, jitter, seed=1):
    """Equilateral lattice of spacing h, rotated by `angle`, vertices jittered by `jitter` h."""
    V, T = waving_disc(1.5 * R, h)
    P = V[:, :2]
    c, s = np.cos(angle), np.sin(angle)
    P = P @ np.array([[c, -s], [s, c]])
    P = P + np.random.default_rng(seed).uniform(-jitter * h, jitter * h, P.shape)
    return _compact(P, T, np.hypot(P[:, 0], P[:, 1]) <= R)


def _samples(lines, step):
    out = []
    for poly in lines.polylines:
        for a, b in zip(poly[:-1], poly[1:]):
            k = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
            out.append(a + (b - a) * (np.arange(k)[:, None] / k))
    return np.concatenate(out) if out else np.zeros((0, 3))


def _nearest(A, B, chunk=2048):
    d = np.empty(len(A))
    for i in range(0, len(A), chunk):
        d[i:i + chunk] = np.sqrt(((A[i:i + chunk, None, :] - B[None, :, :]) ** 2).sum(2).min(1))
    return d


def _mean_edge(V, F):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return float(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1).mean())


def crest_independence(quick):
    R = 2.2 * np.pi
    VA, FA = union_jack(R, 0.16)
    VB, FB = jittered_lattice(R, 0.11, np.radians(17.0), 0.15)
    hA, hB = _mean_edge(VA, FA), _mean_edge(VB, FB)
    h = max(hA, hB)
    rows, data = [], {"triangles_A": int(len(FA)), "triangles_B": int(len(FB)), "edge_A": hA, "edge_B": hB}
    inner = 0.85 * R  # compare away from the boundary, where the fits are one-sided
    for jet in (False, True):
        for T in (0.0, 1.0, 3.0, 10.0):
            la = dgmesh.crest_lines(VA, FA, rings=1, threshold=T, jet=jet)  # exact graphs: the jet is used
            lb = dgmesh.crest_lines(VB, FB, rings=1, threshold=T, jet=jet)
            sa, sb = _samples(la, 0.1 * h), _samples(lb, 0.1 * h)
            sa = sa[np.hypot(sa[:, 0], sa[:, 1]) < inner]
            sb = sb[np.hypot(sb[:, 0], sb[:, 1]) < inner]
            dab, dba = _nearest(sa, sb), _nearest(sb, sa)
            rec = {"lines_A": len(la), "lines_B": len(lb), "mean_AB": float(dab.mean() / h),
                   "mean_BA": float(dba.mean() / h), "median_AB": float(np.median(dab) / h),
                   "within1_A": float((dab < h).mean()), "within1_B": float((dba < h).mean()),
                   "jet_used": [bool(la.derivatives.jet_used), bool(lb.derivatives.jet_used)]}
            fit = "jet (default)" if jet else "thesis (jet=False)"
            data[f"T={T:g}" + (" jet" if jet else "")] = rec
            rows.append([fit, f"{T:g}", f"{len(la)} / {len(lb)}", rec["mean_AB"], rec["mean_BA"], rec["median_AB"],
                         f"{100 * rec['within1_A']:.0f}% / {100 * rec['within1_B']:.0f}%"])
    md = ("### Crest lines: triangulation independence (thesis fig. 4.7)\n\n"
          "The graph z = 0.8 cos(|(x, 1.5 y)|) + 0.6 exp(-|(x, y) - (2, -1)|^2 / 2) over a disc of radius "
          f"{R:.3g}, meshed twice: A, a square grid with alternating diagonals (valence 4/8, {len(FA)} "
          f"triangles, mean edge {hA:.3g}); B, an equilateral lattice rotated by 17 degrees with vertices "
          f"jittered by 15% of the spacing ({len(FB)} triangles, mean edge {hB:.3g}). One-ring fits. "
          "Distances from points on one set of crest lines to the nearest point of the other, over the "
          f"disc of radius {inner:.3g} (boundary fits are one-sided), in units of the larger mean edge "
          f"length h = {h:.3g}.\n\n"
          + table(["fit", "threshold T", "lines A / B", "mean A->B (h)", "mean B->A (h)", "median A->B (h)",
                   "within 1 h (A / B)"], rows)
          + "\n\nUnfiltered, the jittered mesh B has extra short lines (B->A is large); a small threshold "
          "removes them and the two sets agree. Larger thresholds drop different lines on the two meshes "
          "when a crest is traced in several pieces on one of them: T (length x integral) of a piece falls "
          "faster than linearly with its length.\n"
          + "\n`/usr/bin/python3 bench/run.py crest_independence`\n")
    return {"markdown": md, "data": data}


# --- renders (thesis figs. 4.1-4.2, 4.19, 4.26) ------------------------------------------------------

RENDER_SCRIPT = pathlib.Path(__file__).with_name("_crest_render.py")


def _render(name, panels, **meta):
    """Panels side by side, rendered by Blender (Cycles CPU) into bench/images/<name>."""
    arrays = {}
    for i, p in enumerate(panels):
        arrays[f"V{i}"] = np.asarray(p["V"], np.float64)
        arrays[f"F{i}"] = np.asarray(p["F"], np.int32)
        if "colors" in p:
            arrays[f"C{i}"] = np.asarray(p["colors"], np.float32)
        if p.get("wire"):
            arrays[f"W{i}"] = np.ones(1)
        if "lines" in p:
            lines = p["lines"]
            arrays[f"P{i}"] = lines.points[lines.line_points]
            arrays[f"O{i}"] = lines.line_offset
            arrays[f"K{i}"] = lines.line_kind
    meta = dict(meta, panels=len(panels))
    out = IMAGES / name
    IMAGES.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        inp = pathlib.Path(tmp) / "in.npz"
        np.savez(inp, meta=json.dumps(meta), **arrays)
        run_blender(RENDER_SCRIPT, [inp, out])
    return out


def _segment_rgb(labels):
    from dgmesh import colors
    import colorsys
    n = int(labels.max()) + 1
    hues = (np.arange(n) * 0.618033988749895) % 1.0
    rgb = np.array([colorsys.hsv_to_rgb(h, 0.55 + 0.3 * (i % 2), 0.9 - 0.15 * (i % 3 == 2)) for i, h in enumerate(hues)])
    return colors.srgb_to_linear(rgb)[labels]


def crest_renders(quick):
    names, data = [], {}
    size = (360, 270) if not quick else (180, 135)
    samples = 16 if not quick else 4
    prefix = "crest_" if not quick else "quick_crest_"
    t0 = time.perf_counter()
    # T = 10 is the Blender operators' default threshold.
    models = (("fandisk", "Z", (10.0,), (0.6, -1.0, 0.5), 0.0, 0.5),
              ("bunny00", "Y", (10.0, 25.0), (0.0, -1.0, 0.2), 0.0, 0.08),
              ("armadillo", "Y", (10.0, 25.0), (0.0, -1.0, 0.15), 180.0, 0.08))
    for model, up, Ts, view, spin, gap in (models[:1] if quick else models):
        V, F = cgal_mesh(model)
        lines = dgmesh.crest_lines(V, F, rings=1, threshold=0.0)
        panels = [{"V": V, "F": F, "lines": lines}]
        kept = [lines.filter(T) for T in Ts]
        panels += [{"V": V, "F": F, "lines": k} for k in kept]
        name = f"{prefix}lines_{model}.png"
        _render(name, panels, up=up, view=view, spin=spin, gap=gap, size=(len(panels) * size[0], size[1]),
                samples=samples, line=0.0015)
        filt = ", ".join(f"T >= {T:g} ({len(k)})" for T, k in zip(Ts, kept))
        names.append((name, f"{model} ({len(F)} triangles), one-ring fit: every crest line ({len(lines)}, left), "
                            f"then {filt}; ridges blue, valleys red"))
        data[model] = {"lines": len(lines), "kept": {f"{T:g}": len(k) for T, k in zip(Ts, kept)}}
    if not quick:
        V, F = cgal_mesh("bunny00")
        lines = dgmesh.crest_lines(V, F, rings=3, threshold=10.0)
        target = len(F) // 10
        panels = []
        for eta in (0.0, 6.0):
            V2, F2 = dgmesh.decimate(V, F, target_faces=target, feature_weight=eta, crest_lines=lines)
            panels.append({"V": V2, "F": F2, "wire": True})
        name = f"{prefix}decimate_bunny.png"
        _render(name, panels, up="Y", view=(0.0, -1.0, 0.2), size=(2 * 440, 330) if not quick else size,
                samples=samples, wire=0.0009)
        names.append((name, f"bunny00 decimated by 90% ({len(F)} -> {target} triangles): eta = 0 (plain QEM, "
                            f"left) and eta = 6 (right), crest lines k = 3, T >= 10 ({len(lines)} lines)"))
        panels = []
        for eta in (0.0, 2.0):
            labels = dgmesh.segment(V, F, segments=25, feature_weight=eta, crest_lines=lines)
            panels.append({"V": V, "F": F, "colors": _segment_rgb(labels)})
        name = f"{prefix}segment_bunny.png"
        _render(name, panels, up="Y", view=(0.0, -1.0, 0.2), size=(2 * size[0], size[1]), samples=samples)
        names.append((name, "bunny00 in 25 segments (VSA, L^{2,1}): eta = 0 (left) and eta = 2 (right), "
                            "same crest lines"))
        # Triangulation independence (thesis fig. 4.7; bench crest_independence): one graph meshed two ways.
        R = 2.2 * np.pi
        meshes = (union_jack(R, 0.16), jittered_lattice(R, 0.11, np.radians(17.0), 0.15))
        panels = [{"V": Vm, "F": Fm, "wire": True, "lines": dgmesh.crest_lines(Vm, Fm, rings=1, threshold=1.0, jet=jet)}
                  for jet in (False, True) for Vm, Fm in meshes]
        name = f"{prefix}independence.png"
        _render(name, panels, up="Z", view=(0.0, -0.45, 1.0), gap=0.04, size=(4 * size[0], size[1]),
                samples=samples, wire=0.0004, line=0.003)
        names.append((name, "The graph of bench crest_independence meshed as a square grid with alternating "
                            "diagonals and as a rotated, jittered lattice: crest lines (T >= 1, one-ring fits) of "
                            "the thesis fit (jet=False, left pair) and of the jet fit (the default, right pair)"))
    for name, _ in names:
        data[name] = {"bytes": os.path.getsize(IMAGES / name)}
    md = ("### Crest lines: renders\n\nBlender Cycles CPU, " f"{samples} samples, no denoising, "
          f"{size[0]}x{size[1]} per panel.\n\n"
          + "\n\n".join(f"![{cap}](images/{n})\n\n{cap}." for n, cap in names)
          + f"\n\n{time.perf_counter() - t0:.0f} s. `/usr/bin/python3 bench/run.py crest_renders`\n")
    return {"markdown": md, "data": data}


# --- curvature derivatives against exact values and CGAL's jet fitting (issue #31) ----------------

def _implicit_fields(P, g, H, T):
    """Exact principal curvatures, directions and extremality coefficients of an implicit surface
    F = 0 at points P, from the gradient g (n, 3), Hessian H (n, 3, 3) and third derivatives T
    (n, 3, 3, 3) of F, grad F pointing to the side the faces face. k = t^T H t / |g| (positive on
    a sphere with outward faces) and e = dk/dt = (T[t, t, t] - 3 k t^T H n) / |g| (thesis eq. 4.9 with
    this curvature sign; checked against finite differences in tests/python/test_crest_exact.py).
    Returns k1 >= k2, t1, t2, e1, e2."""
    gn = np.linalg.norm(g, axis=1)
    n = g / gn[:, None]
    a = np.where(np.abs(n[:, :1]) < 0.6, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    u = a - (a * n).sum(1)[:, None] * n
    u /= np.linalg.norm(u, axis=1)[:, None]
    w = np.cross(n, u)
    B = np.stack([u, w], 2)  # (n, 3, 2)
    S = np.einsum("nia,nij,njb->nab", B, H, B) / gn[:, None, None]
    lam, vec = np.linalg.eigh(S)  # ascending
    k1, k2 = lam[:, 1], lam[:, 0]
    t1 = np.einsum("nia,na->ni", B, vec[:, :, 1])
    t2 = np.einsum("nia,na->ni", B, vec[:, :, 0])

    def ext(t, k):
        return (np.einsum("nijl,ni,nj,nl->n", T, t, t, t) - 3 * k * np.einsum("nij,ni,nj->n", H, t, n)) / gn
    return k1, k2, t1, t2, ext(t1, k1), ext(t2, k2), n


def ellipsoid_fields(P, a, b, c):
    s = np.array([a, b, c], float) ** -2
    g = 2 * P * s
    H = np.broadcast_to(np.diag(2 * s), (len(P), 3, 3)).copy()
    return _implicit_fields(P, g, H, np.zeros((len(P), 3, 3, 3)))


def torus_fields(P, R, r):
    """F = (|x|^2 + R^2 - r^2)^2 - 4 R^2 (x^2 + y^2)."""
    q = (P ** 2).sum(1) + R * R - r * r
    D = np.diag([1.0, 1.0, 0.0])
    g = 4 * q[:, None] * P - 8 * R * R * P @ D
    I3 = np.eye(3)
    H = 8 * np.einsum("ni,nj->nij", P, P) + 4 * q[:, None, None] * I3 - 8 * R * R * D
    T = 8 * (np.einsum("il,nj->nijl", I3, P) + np.einsum("jl,ni->nijl", I3, P) + np.einsum("ij,nl->nijl", I3, P))
    return _implicit_fields(P, g, H, T)


def monkey_fields(P):
    """F = z - (x^3 - 3 x y^2)."""
    x, y = P[:, 0], P[:, 1]
    g = np.column_stack([-(3 * x * x - 3 * y * y), 6 * x * y, np.ones(len(P))])
    H = np.zeros((len(P), 3, 3))
    H[:, 0, 0], H[:, 0, 1], H[:, 1, 0], H[:, 1, 1] = -6 * x, 6 * y, 6 * y, 6 * x
    T = np.zeros((len(P), 3, 3, 3))
    T[:, 0, 0, 0] = -6.0
    for i, j, l in ((0, 1, 1), (1, 0, 1), (1, 1, 0)):
        T[:, i, j, l] = 6.0
    return _implicit_fields(P, g, H, T)


def waving_fields(P):
    """Exact fields of z = cos(rho) from exact() (meridian / parallel), as k1 >= k2."""
    km, kp, em, ur = exact(P)
    rho = np.hypot(P[:, 0], P[:, 1])
    safe = np.where(rho > 1e-12, rho, 1.0)
    par = np.column_stack([-P[:, 1] / safe, P[:, 0] / safe, np.zeros(len(P))])
    big = km >= kp
    k1, k2 = np.where(big, km, kp), np.where(big, kp, km)
    t1 = np.where(big[:, None], ur, par)
    t2 = np.where(big[:, None], par, ur)
    e1, e2 = np.where(big, em, 0.0), np.where(big, 0.0, em)
    n = np.cross(ur, par)
    return k1, k2, t1, t2, e1, e2, n


def _monkey_disc(R, h):
    V, F = waving_disc(R, h)
    V[:, 2] = V[:, 0] ** 3 - 3 * V[:, 0] * V[:, 1] ** 2
    return V, F


def _ellipsoid(level, a, b, c):
    V, F = shapes.icosphere(level)
    return V * np.array([a, b, c]), F


def derivative_surfaces():
    """(name, (V, F), exact fields) of the known-answer surfaces: the crest_accuracy meshes of the
    waving surface, the issue's mesh of it, an ellipsoid, a torus and a monkey saddle."""
    out = [(name, (V, F), waving_fields(V)) for name, (V, F) in accuracy_meshes()]
    out.insert(0, ("waving, equilateral, h = 0.29, rho <= 2.5 pi (issue #31)", waving_disc(2.5 * np.pi, 0.29), None))
    VE, FE = _ellipsoid(4, 1.0, 0.8, 0.6)
    VT, FT = shapes.torus(1.0, 0.4, 72, 36)
    VM, FM = _monkey_disc(1.0, 0.045)
    out += [("ellipsoid 1 x 0.8 x 0.6 (icosphere level 4 scaled)", (VE, FE), ellipsoid_fields(VE, 1.0, 0.8, 0.6)),
            ("torus R = 1, r = 0.4, 72 x 36 grid (exact e = 0)", (VT, FT), torus_fields(VT, 1.0, 0.4)),
            ("monkey saddle z = x^3 - 3xy^2, equilateral h = 0.045, r <= 1", (VM, FM), monkey_fields(VM))]
    return [(n, m, f if f is not None else waving_fields(m[0])) for n, m, f in out]


def _rings(V, F, k):
    """k-ring of every vertex (the vertex first), breadth first."""
    E = dgmesh.topology(V, F).edges
    adj = [[] for _ in range(len(V))]
    for a, b in E:
        adj[a].append(b)
        adj[b].append(a)
    out = []
    for i in range(len(V)):
        seen, ring, front = {i}, [i], [i]
        for _ in range(k):
            nxt = []
            for v in front:
                for w in adj[v]:
                    if w not in seen:
                        seen.add(w)
                        nxt.append(w)
            ring += nxt
            front = nxt
        out.append(ring)
    return out


def _measured(V, F, fields, rings=2):
    """Vertices whose `rings`-ring stays off the boundary's one-ring, away from umbilics
    (|k1 - k2| > 5% of the largest |k| of the surface)."""
    k1, k2 = fields[0], fields[1]
    keep = np.abs(k1 - k2) > 0.05 * np.abs(np.concatenate([k1, k2])).max()
    top = dgmesh.topology(V, F)
    bnd = np.zeros(len(V), bool)
    for loop in top.boundary_loops:
        bnd[loop] = True
    E = top.edges
    for _ in range(rings + 1):
        grow = bnd.copy()
        grow[E[bnd[E[:, 0]], 1]] = True
        grow[E[bnd[E[:, 1]], 0]] = True
        bnd = grow
    return keep & ~bnd


def _rms(est_e, est_t, e, t, mask):
    s = np.sign(np.einsum("ij,ij->i", est_t, t))
    s[s == 0] = 1
    err = (est_e * s - e)[mask]
    return float(np.sqrt((err ** 2).mean()))


def _errors(d, fields, mask):
    """RMS error of e_max and e_min (sign taken along the exact direction)."""
    k1, k2, t1, t2, e1, e2, _ = fields
    return _rms(d.e_max, d.t_max, e1, t1, mask), _rms(d.e_min, d.t_min, e2, t2, mask)


class _Fields:
    pass


def cgal_jet(V, rings, normals, d=3, m=3):
    """CGAL Monge_via_jet_fitting (d, m) on the given neighbourhoods (vertex first), converted to
    this library's conventions (curvature positive on a sphere with outward normals `normals`).
    Vertices with fewer points than the jet needs get NaN."""
    exe = cgal_tool("cgal_jet_fitting.cpp", "CGAL/Monge_via_jet_fitting.h")
    if exe is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = pathlib.Path(tmp) / "in.txt", pathlib.Path(tmp) / "out.txt"
        with open(src, "w") as f:
            for ring in rings:
                f.write(f"{len(ring)} " + " ".join(f"{x:.17g}" for x in V[ring].ravel()) + "\n")
        subprocess.run([str(exe), str(d), str(m), str(src), str(dst)], check=True)
        rows = [line.split() for line in dst.read_text().splitlines()]
    A = np.array([[float(x) for x in r] if len(r) == 15 else [np.nan] * 15 for r in rows])
    k, b, n, d1, d2 = A[:, 0:2], A[:, 2:6], A[:, 6:9], A[:, 9:12], A[:, 12:15]
    sg = np.sign(np.einsum("ij,ij->i", n, normals))[:, None]
    # Monge z = (k1 x^2 + k2 y^2) / 2 + (b0 x^3 + ...) / 6: k1 is positive where the surface bends
    # towards n, and dk1/dd1 = b0, dk2/dd2 = b3. Here curvature is positive bending away from the
    # outward normal: k = -sg k_cgal, e = -sg b.
    ka, kb = -sg[:, 0] * k[:, 0], -sg[:, 0] * k[:, 1]
    ea, eb = -sg[:, 0] * b[:, 0], -sg[:, 0] * b[:, 3]
    first = ka >= kb
    out = _Fields()
    out.k_max, out.k_min = np.where(first, ka, kb), np.where(first, kb, ka)
    out.e_max, out.e_min = np.where(first, ea, eb), np.where(first, eb, ea)
    out.t_max = np.where(first[:, None], d1, d2)
    out.t_min = np.where(first[:, None], d2, d1)
    return out


DERIV_FITS = [  # (label, rings, options)
    ("ours: jet fit (the default; noise_adaptive: the thesis fit where the mesh looks noisy), 1-ring", 1, {"jet": True}),
    ("ours: jet fit (jet=True; noise_adaptive), 2-ring", 2, {"jet": True}),
    ("ours: jet fit without the noise test (noise_adaptive=False), 1-ring", 1, {"jet": True, "noise_adaptive": False}),
    ("ours: jet fit without the noise test, 2-ring", 2, {"jet": True, "noise_adaptive": False}),
    ("ours: thesis fit (jet=False; p->p', normals, tangent plane, transport), 1-ring", 1, {"jet": False}),
    ("ours: thesis fit (jet=False), 2-ring", 2, {"jet": False}),
    ("thesis fit as printed (p->p', normals, eq. 4.7), 1-ring", 1,
     {"jet": False, "fit_tangent_plane": False, "transport_to_vertex": False}),
]
ZERO = "no estimate (e = 0 everywhere: the RMS of the exact e)"


def _noisy(V, F, sigma, seed):
    """Gaussian noise of standard deviation sigma * mean edge length on every coordinate."""
    return V + np.random.default_rng(seed).normal(0.0, sigma * _mean_edge(V, F), V.shape)


def crest_derivatives(quick):
    surfaces = derivative_surfaces()
    if quick:
        surfaces = surfaces[:1] + surfaces[-3:]
    noises = (0.0, 0.05, 0.1)
    data = {"surfaces": {}}
    sections = []
    for sigma in noises:
        rows = []
        for si, (name, (V0, F), fields) in enumerate(surfaces):
            V = V0 if sigma == 0 else _noisy(V0, F, sigma, 100 + si)
            mask = _measured(V0, F, fields)
            rec = data["surfaces"].setdefault(name, {"triangles": int(len(F)), "measured": int(mask.sum())})
            res = {}
            for label, k, opts in DERIV_FITS:
                d = dgmesh.curvature_derivatives(V, F, rings=k, **opts)
                res[label] = _errors(d, fields, mask)
                if opts.get("jet") and opts.get("noise_adaptive", True) and k == 1:
                    rec.setdefault("noise_ratio", {})[f"{sigma:g}"] = (float(d.noise_ratio), bool(d.jet_used))
            for k in (2, 3):
                c = cgal_jet(V, _rings(V, F, k), fields[6])
                if c is not None:
                    res[f"CGAL jet fitting d = 3, m = 3, {k}-ring"] = _errors(c, fields, mask)
            zero = _Fields()
            zero.e_max = zero.e_min = np.zeros(len(V))
            zero.t_max, zero.t_min = fields[2], fields[3]
            res[ZERO] = _errors(zero, fields, mask)
            rec[f"noise {sigma:g}"] = res
            rows.append((name, len(F), int(mask.sum()), res))
        labels = list(rows[0][3])
        # Where each jet fit does not beat CGAL's 2-ring fit (both of e_max, e_min lower), and where a
        # fit is no better than no estimate at all (e = 0).
        cg = "CGAL jet fitting d = 3, m = 3, 2-ring"
        verdict = []

        def lost(a, b):
            return [str(i + 1) for i, (_, _, _, res) in enumerate(rows)
                    if not (res[a][0] < res[b][0] and res[a][1] < res[b][1])]
        if cg in labels:
            for ours in labels[:4]:
                L = lost(ours, cg)
                verdict.append(f"{ours}: " + (f"does not beat CGAL's 2-ring fit on ({', '.join(L)})"
                                              if L else "beats CGAL's 2-ring fit on every surface"))
        for fit in labels[:2] + [x for x in labels if x.startswith("CGAL")]:
            L = lost(fit, ZERO)
            if L:
                verdict.append(f"{fit}: no better than e = 0 on ({', '.join(L)})")
        tests = [data["surfaces"][n]["noise_ratio"][f"{sigma:g}"] for n, _, _, _ in rows]
        verdict.append(f"noise test (median quartic / cubic residual ratio, threshold {dgmesh.crest.JET_NOISE_RATIO:g}; "
                       "'thesis fit' where it fell back): "
                       + ", ".join(f"({i + 1}) {r:.2f}" + ("" if used else " thesis fit")
                                   for i, (r, used) in enumerate(tests)))
        head = ("Exact meshes" if sigma == 0 else
                f"Gaussian noise, standard deviation {sigma:g} x mean edge length on each coordinate (seeded)")
        # One table per noise level: surfaces as rows would make too many columns; transpose.
        trows = [[l] + [f"{res[l][0]:.4f} / {res[l][1]:.4f}" for _, _, _, res in rows] for l in labels]
        sections.append(f"#### {head}\n\n" + table(["fit"] + [f"({i + 1})" for i in range(len(rows))], trows)
                        + "".join(f"\n\n- {v}" for v in verdict))
    legend = "\n".join(f"{i + 1}. {name}: {nf} triangles, {nm} vertices measured"
                       for i, (name, nf, nm, _) in enumerate(rows))
    md = ("### Crest lines: curvature derivatives against exact values and CGAL's jet fitting (issue #31)\n\n"
          "RMS error of e_max / e_min (each sign taken along the exact principal direction) against the exact "
          "values, over the vertices whose 2-ring stays off the boundary's one-ring and whose |k1 - k2| "
          "exceeds 5% of the surface's largest |k| (no umbilics). CGAL 5.5 `Monge_via_jet_fitting` (d = 3, "
          "m = 3, Eigen) is run in the same bench run on the same k-ring of each vertex "
          "(bench/tools/cgal_jet_fitting.cpp); a 1-ring CGAL fit is not possible with d = 3 (7 points on a "
          "valence-6 vertex, 10 needed). Exact fields: z = cos(rho) from its meridian / parallel formulas; "
          "the ellipsoid, torus and monkey saddle from eq. 4.9 of their implicit equations (the torus's e "
          "is 0: its principal curvatures are constant along their own lines of curvature). Our fits see "
          "only the mesh; the CGAL conversion uses the exact normal to orient its Monge frame.\n\n"
          "Surfaces:\n\n" + legend + "\n\n" + "\n\n".join(sections)
          + "\n\nWith jet=True a noise test decides between the jet fit and the thesis fit (noise_adaptive, on by "
          "default): a cubic and a quartic jet fitted to the 2-ring heights of up to 2048 vertices; where the quartic "
          "leaves as much residual as the cubic (median ratio above the threshold) the residual is noise, not "
          "truncation, and the thesis fit (p->p' smoothing) is used. The rows 'without the noise test' are the jet fit "
          "alone. 'No estimate' is the error of answering e = 0 everywhere: under this much noise a fit below that "
          "row carries information, one above it does not (on the finely meshed ellipsoid, torus and monkey saddle no "
          "fit, ours or CGAL's, does at 0.05). The jet fit is the default. For crest lines, on a G1 blend (the rounded "
          "cube's edges) k_max is constant across the blend, the jet resolves that plateau (e = 0 to round-off) and "
          "would trace lines off the blend's middle, so there (DerivativeOptions.plateaus) the lines are traced on "
          "the thesis fit, whose smoothing puts one on the middle. Between the exact meshes and 0.05 "
          "(bench/tools/crest_noise_sweep.py) and why more rings hurt the thesis fit: "
          "bench/notes/crest_derivatives.md."
          + "\n\n`/usr/bin/python3 bench/run.py crest_derivatives`\n")
    return {"markdown": md, "data": data}


WORKLOADS = {"crest_accuracy": crest_accuracy, "crest_derivatives": crest_derivatives, "crest_independence": crest_independence,
             "crest_speed": crest_speed, "crest_renders": crest_renders}
