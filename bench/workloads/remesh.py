"""Remeshing by double parameterization (thesis 5.4) workloads.

    /usr/bin/python3 bench/run.py remesh_quality remesh_speed

remesh_quality: the disk scans of Debian's CGAL data, remeshed to 5000 vertices (boundary
resampled at the target spacing, uniform density) at 256^2 with the three schemes of thesis fig.
5.6-5.9: single (U0), single (Uopt) and double (sample on Uopt, Delaunay on U0), each with four
post-processing variants applied identically to the three modes: plain error diffusion (the thesis),
+ Lloyd relaxation and minimum separation, + 3D Delaunay edge flips, + tangential smoothing on the
surface (the default). Measured: vertex-count accuracy, minimum angle,
share of triangles with an angle below 30 degrees, edge-length coefficient of variation (sampling
uniformity: 0 for equal edges), two-sided Hausdorff distance to the input over the bbox diagonal
(output vertices and face centroids to the input, input vertices to the output) and time.

remesh_speed: 100K target vertices at 1024^2 (at most one sample per pixel, so 256^2 cannot hold
100K) on lion-head and mannequin-devil: wall and process CPU time with the stage breakdown.
"""

import os
import resource
import time

import numpy as np

import dgmesh
from bench.common import bbox_diagonal, cgal_mesh, machine, median_time, table

MODELS = ("lion-head", "mannequin-devil", "mushroom", "nefertiti", "three_peaks")
MODES = ("single_u0", "single_uopt", "double")
# Post-processing variants, the same for the three modes. "plain" is the thesis's scheme as published.
VARIANTS = {
    "plain": dict(lloyd_iterations=0, min_separation=0.0, flip_3d=False, smooth_iterations=0),
    "relaxed": dict(lloyd_iterations=4, min_separation=0.35, flip_3d=False, smooth_iterations=0),
    "relaxed+flips": dict(lloyd_iterations=4, min_separation=0.35, flip_3d=True, smooth_iterations=0),
    "relaxed+flips+smooth (default)": dict(lloyd_iterations=4, min_separation=0.35, flip_3d=True,
                                           smooth_iterations=3),
}


def _cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _angles(V, F):
    out = []
    for k in range(3):
        a, b, c = V[F[:, k]], V[F[:, (k + 1) % 3]], V[F[:, (k + 2) % 3]]
        u, v = b - a, c - a
        cos = (u * v).sum(1) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.stack(out, 1)


def _edge_cv(V, F):
    E = np.unique(np.sort(np.r_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1), axis=0)
    L = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    return float(L.std() / L.mean())


def _hausdorff(V, F, W, G):
    P = np.r_[W, W[G].mean(1)]
    Q = np.r_[V, V[F].mean(1)]
    d = max(dgmesh.point_mesh_distance(P, V, F).max(), dgmesh.point_mesh_distance(Q, W, G).max())
    return float(d) / bbox_diagonal(V)


def _verdict(double, best_single, tie):
    """'yes' when double beats the best single by more than `tie`, 'tie' within it, else 'no'."""
    return "yes" if double > best_single + tie else "tie" if double >= best_single - tie else "no"


def remesh_quality(quick):
    models = MODELS[:1] if quick else MODELS
    target, res = (2000, 256) if quick else (5000, 256)
    rows, data = [], {"target": target, "resolution": res, "models": {}}
    wins = []
    for name in models:
        V, F = cgal_mesh(name)
        per = {}
        for (variant, opts), mode in ((v, m) for v in VARIANTS.items() for m in MODES):
            c0, w0 = _cpu_seconds(), time.perf_counter()
            r = dgmesh.remesh_full(V, F, target_vertices=target, resolution=res, mode=mode, boundary="resample",
                                   **opts)
            t, cpu = time.perf_counter() - w0, _cpu_seconds() - c0
            A = _angles(r.V, r.F)
            m = dict(vertices=len(r.V), count_error=(len(r.V) - target) / target, min_angle=float(A.min()),
                     below30=float((A.min(1) < 30).mean()), edge_cv=_edge_cv(r.V, r.F),
                     hausdorff=_hausdorff(V, F, r.V, r.F), seconds=t, cpu=cpu, flips=r.n_flips,
                     dropped=r.n_separated, rounds=r.sampling_rounds)
            per[f"{mode}/{variant}"] = m
            rows.append((name, f"{len(V)}", mode, variant, m["vertices"],
                         f"{100 * m['count_error']:+.2f}%", m["min_angle"], f"{100 * m['below30']:.1f}%",
                         m["edge_cv"], m["hausdorff"], m["cpu"]))
        for label in VARIANTS:
            d, a, b = (per[f"{m}/{label}"] for m in ("double", "single_u0", "single_uopt"))
            wins.append((name, label, _verdict(d["min_angle"], max(a["min_angle"], b["min_angle"]), 0.5),
                         _verdict(-d["edge_cv"], -min(a["edge_cv"], b["edge_cv"]), 0.01 * d["edge_cv"]),
                         _verdict(-d["below30"], -min(a["below30"], b["below30"]), 0.001)))
        data["models"][name] = {"vertices": len(V), "faces": len(F), "runs": per}
    m = machine()
    md = "\n".join([
        f"Remeshing by double parameterization (thesis 5.4, fig. 5.6-5.9) on the disk scans of Debian's CGAL "
        f"data: {target} target vertices, {res}^2 control map, uniform density, boundary resampled at the "
        "target spacing, U0 = Floater on the unit circle, Uopt = stretch equalization (eta 1) from it. "
        "Variants, applied identically to the three modes: 'plain' = the thesis's scheme (error diffusion, "
        "Delaunay in the triangulation map, lift); 'relaxed' = + 4 Lloyd steps after the error diffusion (each interior "
        "sample moves to the control-map mass centroid of its Voronoi cell, cells in the surface metric over the "
        "sampling map's pixels, boundary samples fixed; Lloyd 1982, as in Alliez et al. 2003 'Isotropic surface "
        "remeshing') and dropping samples closer than 0.35 x the target spacing, repeated with a raised diffusion "
        "goal until the count is within 0.5% (so every mode hits the count); '+flips' = 3D Delaunay edge flips "
        "after the parameter-space Delaunay, kept an embedding of the map, across near-flat edges or where the "
        "flip unfolds a fold; '+smooth' = 3 sweeps of tangential smoothing of the new vertices on the surface "
        "(area-weighted centroid of the star, moved inside the triangulation map so no map triangle flips; a "
        "move may not create a 3D angle below 30 degrees, vertices on sharp features only move to lift such an "
        "angle), each followed by the flips. All beyond 'plain' is beyond the thesis. "
        "Angles in degrees; '<30' = share of triangles with an angle below 30 degrees; edge CV = standard "
        "deviation / mean of the edge lengths (sampling uniformity); Hausdorff = two-sided, over the bbox "
        "diagonal. CPU = process CPU seconds of one whole remesh (both parameterizations included). "
        f"{m['cpu']}, {m['threads']} threads, load {os.getloadavg()[0]:.1f}, {m['date']}, commit {m['commit']}.",
        "",
        table(["model", "input V", "mode", "variant", "V", "count err", "min angle", "<30", "edge CV",
               "Hausdorff", "CPU s"], rows),
        "",
        "Does double beat both singles (same sampling and triangulation options for all three)? 'tie' = within "
        "0.5 degree of minimum angle, 1% of edge CV, 0.1 percentage point of share <30.",
        "",
        table(["model", "variant", "min angle", "uniformity (edge CV)", "share <30"], wins),
        "",
        "Wins of double over both singles, per variant (out of %d models): " % len(models) + "; ".join(
            f"{v}: " + ", ".join(
                f"{metric} {sum(w[k] == 'yes' for w in wins if w[1] == v)} won / "
                f"{sum(w[k] == 'tie' for w in wins if w[1] == v)} tied"
                for k, metric in ((2, "min angle"), (3, "edge CV"), (4, "share <30")))
            for v in VARIANTS) + ".",
        "",
        "Hausdorff (median over models) per variant and mode: " + "; ".join(
            f"{v}: " + ", ".join(
                f"{mo} {np.median([data['models'][n]['runs'][f'{mo}/{v}']['hausdorff'] for n in models]):.4f}"
                for mo in MODES) for v in VARIANTS) + ".",
        "",
        "Notes. The minimum angle is one triangle: without smoothing it sits at a sharp fold or a scan defect "
        "where the triangulation map is strongly anisotropic, so a 3D-Delaunay flip there would fold the map "
        "and is refused; the default smoothing ends with a pattern search on every star still holding an "
        "angle under 30 degrees, which lifts the worst triangles of every mode towards 30 degrees, so "
        "where the maps allow it the modes tie there (ties are within 0.5 degree); single_u0's "
        "minimum-angle results come with an edge CV 4-5x that of double on the curved scans. nefertiti (299 input vertices, nearly developable) has U0 close to Uopt: double and "
        "single_uopt sample nearly the same points (the same edge CV) and the three modes differ by a few "
        "percent: a structural tie, not something the double scheme can win. single_u0 hits the count only by oversampling the parts of U0 "
        "whose pixels are small on the surface (the separation drops the crowded samples elsewhere), hence its "
        "edge CV and Hausdorff: the thesis's fig. 5.8 point. The smoothing trades some fidelity at sharp "
        "features for angles and uniformity (compare the Hausdorff of '+flips' and '+smooth').",
        "",
        "Reproduce: `/usr/bin/python3 bench/run.py remesh_quality`",
    ])
    data["double_beats_singles"] = wins
    return {"markdown": md, "data": data}


def remesh_speed(quick):
    target, res = (20000, 512) if quick else (100000, 1024)
    rows, data = [], {"target": target, "resolution": res, "runs": {}}
    for name in ("lion-head", "mannequin-devil"):
        V, F = cgal_mesh(name)
        for post in (False, True):
            # post: the default flips + 3 smoothing sweeps; without: the Delaunay in U0 as is.
            opts = {} if post else dict(flip_3d=False, smooth_iterations=0)
            runs = []
            for _ in range(1 if quick else 3):
                c0 = _cpu_seconds()
                t, r = median_time(lambda: dgmesh.remesh_full(V, F, target_vertices=target, resolution=res,
                                                              mode="double", boundary="resample", **opts),
                                   repeats=1, warmup=0)
                runs.append((t, _cpu_seconds() - c0, r))
            runs.sort(key=lambda x: x[0])
            t, cpu, r = runs[len(runs) // 2]
            s = r.seconds
            rows.append((name, len(V), "flips+smooth (default)" if post else "none", len(r.V), t, cpu, s["parameterize"], s["sample"],
                         s["relax"], s["triangulate"], "yes" if t <= 3.0 else "no"))
            data["runs"][f"{name}{'+post' if post else ''}"] = dict(vertices=len(r.V), wall=t, cpu=cpu, **s)
    m = machine()
    md = "\n".join([
        f"Double-parameterization remesh to {target} vertices at {res}^2 (target: <= 3 s). Wall = median of "
        f"{1 if quick else 3} runs; CPU = user+sys of the process during that run (all threads); stages: both "
        "parameterizations (U0, Uopt), rasterization + error diffusion + sample mapping, 4 Lloyd steps + "
        f"minimum separation (relax), Delaunay (Qhull) + lift (+ 3D flips and 3 tangential smoothing sweeps, the default "
        f"post-processing). {m['cpu']}, {m['threads']} threads, load {os.getloadavg()[0]:.1f}, {m['date']}, "
        f"commit {m['commit']}.",
        "",
        table(["model", "input V", "post-processing", "output V", "wall s", "CPU s", "parameterize s", "sample s",
               "relax s", "triangulate s", "<= 3 s"], rows),
        "",
        "Reproduce: `/usr/bin/python3 bench/run.py remesh_speed`",
    ])
    return {"markdown": md, "data": data}


WORKLOADS = {"remesh_quality": remesh_quality, "remesh_speed": remesh_speed}
