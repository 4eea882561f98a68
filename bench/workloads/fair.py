"""Fairing workloads (thesis chapter 3): energy checks on known shapes, hole restoration on
scanned meshes, speed of the explicit and semi-implicit schemes.

    /usr/bin/python3 bench/run.py fair_energy fair_restore fair_speed fair_renders
"""

import heapq
import os
import pathlib
import resource
import subprocess
import tempfile
import time

import numpy as np

import dgmesh
from bench.common import bbox_diagonal, cgal_mesh, table
from bench.common import cgal_tool as common_cgal_tool
from dgmesh.fairing import refine_region
from dgmesh.polymesh.measures import min_angle_deg



# ---------------------------------------------------------------------------------------------
# Hole cutting, flat filling, distances
# ---------------------------------------------------------------------------------------------

def _edges(F):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E.sort(axis=1)
    return np.unique(E, axis=0)


def geodesic_ball(V, F, centre, area_fraction):
    """Faces of a geodesic (Dijkstra over edges) ball around vertex `centre` holding about
    `area_fraction` of the surface area."""
    E = _edges(F)
    n = len(V)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    order = np.argsort(np.concatenate([E[:, 0], E[:, 1]]), kind="stable")
    src = np.concatenate([E[:, 0], E[:, 1]])[order]
    dst = np.concatenate([E[:, 1], E[:, 0]])[order]
    ww = np.concatenate([w, w])[order]
    start = np.searchsorted(src, np.arange(n + 1))
    dist = np.full(n, np.inf)
    dist[centre] = 0.0
    heap = [(0.0, centre)]
    fa = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    target = area_fraction * fa.sum()
    # Vertex areas (a third of the adjacent faces) to know when the ball is big enough.
    va = np.zeros(n)
    np.add.at(va, F.ravel(), np.repeat(fa / 3, 3))
    grown = 0.0
    done = np.zeros(n, dtype=bool)
    while heap and grown < target:
        d, v = heapq.heappop(heap)
        if done[v]:
            continue
        done[v] = True
        grown += va[v]
        for j in range(start[v], start[v + 1]):
            u, nd = dst[j], d + ww[j]
            if nd < dist[u]:
                dist[u] = nd
                heapq.heappush(heap, (nd, u))
    return done[F].all(axis=1)


def cut_hole(V, F, centre, area_fraction):
    """Removes a geodesic disk: returns (hole_faces mask, interior vertex mask) if the removed
    faces form a disk whose rim is a single simple loop, else None."""
    hole = geodesic_ball(V, F, centre, area_fraction)
    if hole.sum() < 10:
        return None
    kept_v = np.zeros(len(V), dtype=bool)
    kept_v[F[~hole].ravel()] = True
    inner = np.zeros(len(V), dtype=bool)
    inner[F[hole].ravel()] = True
    inner &= ~kept_v
    # Disk check: Euler characteristic 1 and one boundary loop.
    Fh = F[hole]
    used = np.unique(Fh)
    chi = len(used) - len(_edges(Fh)) + len(Fh)
    try:
        loops = dgmesh.topology(V, Fh).boundary_loops
    except dgmesh.MeshError:
        return None
    if chi != 1 or len(loops) != 1:
        return None
    return hole, inner


def membrane_fill(V, F, hole, inner):
    """The flat starting patch: the removed faces' connectivity with the interior vertices at
    the uniform-Laplacian (membrane) interpolation of the rim -- the 'flat' surface spanning the
    hole, with well-shaped triangles. Conjugate gradients on the graph Laplacian (numpy only)."""
    n = len(V)
    E = _edges(F[hole])
    idx = np.flatnonzero(inner)
    loc = np.full(n, -1)
    loc[idx] = np.arange(len(idx))
    deg = np.bincount(E.ravel(), minlength=n).astype(float)
    a, b = E[:, 0], E[:, 1]
    ia, ib = loc[a], loc[b]
    both = (ia >= 0) & (ib >= 0)

    def apply(x):  # (D - A) x over interior vertices
        y = deg[idx, None] * x
        for c in range(3):
            y[:, c] -= np.bincount(ia[both], weights=x[ib[both], c], minlength=len(idx))
            y[:, c] -= np.bincount(ib[both], weights=x[ia[both], c], minlength=len(idx))
        return y

    rhs = np.zeros((len(idx), 3))
    for c in range(3):  # fixed (rim) neighbours move to the right-hand side
        m1 = (ia >= 0) & (ib < 0)
        m2 = (ib >= 0) & (ia < 0)
        rhs[:, c] += np.bincount(ia[m1], weights=V[b[m1], c], minlength=len(idx))
        rhs[:, c] += np.bincount(ib[m2], weights=V[a[m2], c], minlength=len(idx))
    x = np.zeros_like(rhs)
    r = rhs - apply(x)
    p = r.copy()
    rs = (r * r).sum(0)
    for _ in range(5000):
        Ap = apply(p)
        alpha = rs / np.maximum((p * Ap).sum(0), 1e-300)
        x += p * alpha
        r -= Ap * alpha
        rs_new = (r * r).sum(0)
        if np.sqrt(rs_new.max()) < 1e-12 * max(1.0, np.abs(rhs).max()):
            break
        p = r + p * (rs_new / np.maximum(rs, 1e-300))
        rs = rs_new
    W = V.copy()
    W[idx] = x
    return W


def _closest_on_triangles(p, A, B, C):
    """Closest points on triangles (A, B, C) (each (k, 3)) to points p (k, 3) (Ericson 5.1.5)."""
    ab, ac, ap = B - A, C - A, p - A
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - B
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - C
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(np.abs(denom) < 1e-300, 1e-300, denom)
    v = vb / denom
    w = vc / denom
    out = A + ab * v[..., None] + ac * w[..., None]  # interior
    # Edge regions.
    def edge(mask, P0, d, t):
        return np.where(mask[..., None], P0 + d * np.clip(t, 0, 1)[..., None], out)

    t_ab = d1 / np.where(np.abs(d1 - d3) < 1e-300, 1e-300, d1 - d3)
    out = edge((vc <= 0) & (d1 >= 0) & (d3 <= 0), A, ab, t_ab)
    t_ac = d2 / np.where(np.abs(d2 - d6) < 1e-300, 1e-300, d2 - d6)
    out = edge((vb <= 0) & (d2 >= 0) & (d6 <= 0), A, ac, t_ac)
    den_bc = (d4 - d3) + (d5 - d6)
    t_bc = (d4 - d3) / np.where(np.abs(den_bc) < 1e-300, 1e-300, den_bc)
    out = edge((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), B, C - B, t_bc)
    # Vertex regions.
    out = np.where(((d1 <= 0) & (d2 <= 0))[..., None], A, out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[..., None], B, out)
    out = np.where(((d6 >= 0) & (d5 <= d6))[..., None], C, out)
    return out


def closest_points(P, V, F, candidates=24, chunk=256):
    """Closest point on the triangle mesh (V, F) to each point of P: exact point-triangle distance
    to the `candidates` triangles with the nearest centroids."""
    cen = V[F].mean(1)
    k = min(candidates, len(F))
    out = np.empty((len(P), 3))
    for s in range(0, len(P), chunk):
        p = P[s:s + chunk]
        d2 = ((p[:, None, :] - cen[None, :, :]) ** 2).sum(-1)
        cand = np.argpartition(d2, k - 1, axis=1)[:, :k]
        T = F[cand]
        q = _closest_on_triangles(p[:, None, :], V[T[..., 0]], V[T[..., 1]], V[T[..., 2]])
        best = ((q - p[:, None, :]) ** 2).sum(-1).argmin(1)
        out[s:s + chunk] = q[np.arange(len(p)), best]
    return out


def point_surface_distance(P, V, F, candidates=24, chunk=256):
    """Distance from each point of P to the triangle mesh (V, F)."""
    return np.linalg.norm(closest_points(P, V, F, candidates, chunk) - P, axis=1)


def sample_faces(V, F, per_face=3, seed=0, weights=False):
    """Random points on the faces (plus the vertices), for symmetric distances. With `weights`,
    also the surface area each point stands for (a face's area split over its samples; 0 for the
    vertices, which only serve the maximum), so that weighted means are means over the surface."""
    rng = np.random.default_rng(seed)
    r = rng.random((len(F), per_face, 2))
    flip = r.sum(-1) > 1
    r[flip] = 1 - r[flip]
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    pts = A[:, None] + (B - A)[:, None] * r[..., :1] + (C - A)[:, None] * r[..., 1:]
    pts = np.concatenate([pts.reshape(-1, 3), V[np.unique(F)]])
    if not weights:
        return pts
    area = 0.5 * np.linalg.norm(np.cross(B - A, C - A), axis=1)
    w = np.concatenate([np.repeat(area / per_face, per_face), np.zeros(len(pts) - per_face * len(F))])
    return pts, w


_PER_FACE = [3]  # samples per face for patch distances (quick mode: 1)


def patch_distances(V_orig, F, hole, V_new, F_new, new_region):
    """Symmetric patch-to-original distances: restored patch samples to the removed original
    surface and back. Returns (mean, max). The mean is the average of the two directions' means
    over surface area (Metro's mean distance): each direction weights its samples by the area they
    stand for. A plain average over the samples (3 per face) weighted the surfaces by their
    triangle counts: the same surface triangulated more finely near the rim (where every fill is
    close to the original) came out closer (a coarse-to-fine Willmore patch at 0.0001 of the
    diagonal from the refined-fill one measured 0.0071 against 0.0096 on bunny00 10% seed 2), and a
    patch with more faces weighted its own direction more."""
    Fo = F[hole]
    Fr = F_new[new_region]
    pa, wa = sample_faces(V_new, Fr, _PER_FACE[0], weights=True)
    pb, wb = sample_faces(V_orig, Fo, _PER_FACE[0], weights=True)
    a = point_surface_distance(pa, V_orig, Fo)
    b = point_surface_distance(pb, V_new, Fr)
    mean = 0.5 * (np.average(a, weights=wa) + np.average(b, weights=wb))
    return float(mean), float(max(a.max(), b.max()))


def rim_crease(V, F, region):
    """Mean dihedral angle (degrees) across the edges between the region's faces and the rest: how
    sharply a patch meets the surface around it (on the original mesh: the scan's own bend there)."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    a, b = dgmesh.topology(V, F).edge_faces.T
    rim = (b >= 0) & (region[a] != region[np.maximum(b, 0)])
    cos = np.clip((n[a[rim]] * n[b[rim]]).sum(axis=1), -1.0, 1.0)
    return float(np.degrees(np.arccos(cos)).mean())


def fan_fill(V, F, hole, inner):
    """What a user gets from Fill on the hole: the removed faces replaced by a fan over the rim loop
    (no inner vertex; the removed interior vertices stay, unused). Returns (F2, fill face mask)."""
    rim = set(np.setdiff1d(np.unique(F[hole]), np.flatnonzero(inner)).tolist())
    loops = dgmesh.topology(V, F[~hole]).boundary_loops
    loop = next(lp for lp in loops if rim.issuperset(lp))
    fan = np.array([[loop[0], loop[i + 1], loop[i]] for i in range(1, len(loop) - 1)], dtype=F.dtype)
    F2 = np.concatenate([F[~hole], fan])
    region = np.zeros(len(F2), dtype=bool)
    region[len(F2) - len(fan):] = True
    return F2, region


def find_hole(V, F, fraction, seed):
    """A valid disk-shaped hole of about `fraction` of the area around a random vertex."""
    rng = np.random.default_rng(seed)
    for _ in range(50):
        c = int(rng.integers(len(V)))
        got = cut_hole(V, F, c, fraction)
        if got is not None:
            return c, got
    raise RuntimeError("no disk-shaped hole found")


def _timed(fn):
    t0 = time.perf_counter()
    r = fn()
    return time.perf_counter() - t0, r


def fair_energy(quick):
    """Energy checks: sphere (4 pi), ellipsoid rounding up, Clifford torus (2 pi^2)."""
    rows, data = [], {}
    Vs, Fs = dgmesh.shapes.icosphere(3 if quick else 4)
    Ve = Vs * np.array([2.0, 1.0, 1.0])
    Vt, Ft = dgmesh.shapes.torus(np.sqrt(2), 1.0, 64 if quick else 128, 32 if quick else 64)
    for name, V, F, exact in [("sphere", Vs, Fs, 4 * np.pi), ("ellipsoid 2:1:1", Ve, Fs, 4 * np.pi),
                              ("torus R/r = sqrt 2", Vt, Ft, 2 * np.pi ** 2)]:
        for scheme in ("explicit", "semi_implicit"):
            secs, r = _timed(lambda: dgmesh.fair(V, F, scheme=scheme, max_iterations=2000 if scheme == "explicit" else 300))
            ext = r.vertices.max(0) - r.vertices.min(0)
            mono = bool(np.all(np.diff(r.energy) <= 1e-6 * r.energy[:-1]))
            rows.append([name, scheme, len(V), float(r.energy[0]), float(r.energy[-1]), float(exact),
                         float(ext.max() / ext.min()), r.iterations, str(r.converged), str(mono), secs])
            data[f"{name}/{scheme}"] = dict(zip(["E0", "E", "exact", "aspect", "iterations", "seconds"],
                                               [rows[-1][3], rows[-1][4], rows[-1][5], rows[-1][6], r.iterations, secs]))
    md = ("Willmore energy (sum H^2 A, mixed areas) before/after `dgmesh.fair` (Willmore, default tolerance 1e-4), "
          "explicit capped at 2000 iterations.\n\n" + table(
              ["shape", "scheme", "vertices", "E input", "E output", "exact", "bbox aspect", "iterations",
               "converged", "monotone", "s"], rows)
          + "\n\nReproduce: `/usr/bin/python3 bench/run.py fair_energy`")
    return {"markdown": md, "data": data}


# ---------------------------------------------------------------------------------------------
# CGAL reference on the same holes (bench/tools/cgal_fair_hole.cpp, compiled here on demand)
# ---------------------------------------------------------------------------------------------

def cgal_tool(build=True):
    """Path of the CGAL reference tool (bench/tools/cgal_fair_hole.cpp), built with g++ against
    Debian's libcgal-dev on first use (about 40 s; not when `build` is False); None when g++ or the
    CGAL headers are missing."""
    return common_cgal_tool("cgal_fair_hole.cpp", "CGAL/Polygon_mesh_processing/fair.h", build)


def _write_off(path, V, F):
    with open(path, "w") as f:
        f.write(f"OFF\n{len(V)} {len(F)} 0\n")
        np.savetxt(f, V, fmt="%.17g")
        np.savetxt(f, np.c_[np.full(len(F), 3), F], fmt="%d")


def _read_off(path):
    with open(path) as f:
        f.readline()
        nv, nf, _ = map(int, f.readline().split())
        data = f.read().split()
    V = np.array(data[:3 * nv], float).reshape(-1, 3)
    F = np.array(data[3 * nv:3 * nv + 4 * nf], int).reshape(-1, 4)[:, 1:]
    return V, F


def cgal_restore(V, F, hole, inner, V0, build=True):
    """CGAL 5.5 on the same hole: (a) triangulate_refine_and_fair_hole on the mesh with the hole
    cut out (its own Liepa triangulation, refinement and cotangent bi-Laplacian fairing), (b)
    Polygon_mesh_processing::fair of our flat fill's interior vertices (our connectivity).
    (c) triangulate_and_refine_hole alone: a fresh refined flat fill whose connectivity owes nothing
    to the removed original (our fill keeps the scan's connectivity, which carries information about
    the removed shape into the connectivity-based uniform bi-umbrella).
    Returns {"refine_and_fair": (V, F, seconds), "fair": (V, seconds), "refined_fill": (V, F,
    patch face mask, moving vertex mask)}; missing entries when the
    tool is unavailable or CGAL reports a failure. Seconds include the tool's OFF I/O."""
    exe = cgal_tool(build)
    if exe is None:
        return {}
    out = {}
    keep = ~inner
    newidx = np.full(len(V), -1)
    newidx[keep] = np.arange(int(keep.sum()))
    rim = np.setdiff1d(np.unique(F[hole]), np.flatnonzero(inner))
    with tempfile.TemporaryDirectory() as d:
        d = pathlib.Path(d)
        _write_off(d / "hole.off", V[keep], newidx[F[~hole]])
        t0 = time.perf_counter()
        p = subprocess.run([str(exe), "trf", str(d / "hole.off"), str(int(newidx[rim[0]])), str(d / "trf.off")],
                           capture_output=True, text=True)
        secs = time.perf_counter() - t0
        if p.returncode == 0:
            Vt, Ft = _read_off(d / "trf.off")
            out["refine_and_fair"] = (Vt, Ft, secs)
        p = subprocess.run([str(exe), "tr", str(d / "hole.off"), str(int(newidx[rim[0]])), str(d / "tr.off")],
                           capture_output=True, text=True)
        if p.returncode == 0:
            Vr, Fr = _read_off(d / "tr.off")
            region = np.zeros(len(Fr), dtype=bool)
            region[int((~hole).sum()):] = True  # the tool writes the patch faces last
            moving = np.zeros(len(Vr), dtype=bool)
            moving[int(keep.sum()):] = True  # CGAL's new vertices follow the input's
            out["refined_fill"] = (Vr, Fr, region, moving)
    faired = cgal_fair(V0, F, inner, build)
    if faired is not None:
        out["fair"] = faired
    return out


def _region_energy(V, F, inner):
    """Willmore energy of the region (moving vertices and their first fixed ring)."""
    return float(dgmesh.fair(V, F, mask=inner, max_iterations=0).energy[0])


def _sphere_hole(frac):
    """Known answer: a hole in a unit icosphere (level 4), whose Willmore restoration is the sphere."""
    V, F = dgmesh.shapes.icosphere(4)
    hole, inner = cut_hole(V, F, 0, frac)
    return V, F, hole, inner


def fair_restore(quick):
    """Hole restoration on a known answer (sphere) and scanned meshes: remove a geodesic disk,
    fill it flat (membrane), restore with each method; symmetric distance patch <-> removed
    original / bbox diagonal, and the region's Willmore energy."""
    rows, data = [], {}
    groups = []  # per row: "a" (our fill), "b" (CGAL's refined fill), "c" (fan + refine)
    _PER_FACE[0] = 1 if quick else 3
    cases = []
    for frac in ([0.3] if quick else [0.1, 0.3]):
        cases.append(("icosphere(4)", frac, 0, _sphere_hole(frac)))
    meshes = [("bunny00", 0.08)] if quick else [("bunny00", 0.05), ("bunny00", 0.10),
                                                ("camel", 0.05), ("camel", 0.10)]
    seeds = [0] if quick else [0, 1, 2]
    for name, frac in meshes:
        V, F = cgal_mesh(name)
        for seed in seeds:
            _c, (hole, inner) = find_hole(V, F, frac, seed)
            cases.append((name, frac, seed, (V, F, hole, inner)))
    wins = []
    for name, frac, seed, (V, F, hole, inner) in cases:
        diag = bbox_diagonal(V)
        V0 = membrane_fill(V, F, hole, inner)
        nrim = len(np.setdiff1d(np.unique(F[hole]), np.flatnonzero(inner)))
        head = [name, frac, seed, int(inner.sum()), nrim]
        e_orig = _region_energy(V, F, inner)
        rows.append(head + ["original", 0.0, 0.0, e_orig, "", 0, 0.0])
        d0 = patch_distances(V, F, hole, V0, F, hole)
        rows.append(head + ["flat fill", d0[0] / diag, d0[1] / diag, _region_energy(V0, F, inner), "", 0, 0.0])
        key = f"{name}/{frac}/{seed}"
        got = {}
        for method in ("willmore", "bilaplacian") + (() if quick else ("laplacian_of_h",)):
            secs, r = _timed(lambda: dgmesh.fair(V0, F, mask=inner, method=method))
            d = patch_distances(V, F, hole, r.vertices, r.faces, hole)
            got[method] = d[0] / diag
            rows.append(head + [method, d[0] / diag, d[1] / diag, float(r.energy[-1]),
                                "yes" if r.linear_start else "", r.iterations, secs])
            data[f"{key}/{method}"] = {"mean": d[0] / diag, "max": d[1] / diag, "E": float(r.energy[-1]),
                                       "linear_start": bool(r.linear_start),
                                       "iterations": r.iterations, "seconds": secs}
        cg = cgal_restore(V, F, hole, inner, V0, build=not quick)
        groups.extend("a" * (len(rows) - len(groups)))
        if "refine_and_fair" in cg:
            Vt, Ft, secs = cg["refine_and_fair"]
            d = patch_distances(V, F, hole, Vt, Ft, np.ones(len(Ft), dtype=bool))
            got["cgal_trf"] = d[0] / diag
            rows.append(head + ["CGAL triangulate_refine_and_fair_hole", d[0] / diag, d[1] / diag, "", "", 0, secs])
            data[f"{key}/cgal_trf"] = {"mean": d[0] / diag, "max": d[1] / diag, "faces": len(Ft), "seconds": secs}
        if "fair" in cg:
            Vc, secs = cg["fair"]
            d = patch_distances(V, F, hole, Vc, F, hole)
            got["cgal_fair"] = d[0] / diag
            rows.append(head + ["CGAL fair (our fill)", d[0] / diag, d[1] / diag, _region_energy(Vc, F, inner), "", 0,
                                secs])
            data[f"{key}/cgal_fair"] = {"mean": d[0] / diag, "max": d[1] / diag, "seconds": secs}
        if "refined_fill" in cg and not quick:  # quick mode: keep it under a minute
            # Same comparison on CGAL's own refined fill (the connectivity CGAL's fairing uses).
            Vr, Fr, region, moving = cg["refined_fill"]
            d = patch_distances(V, F, hole, Vr, Fr, region)
            hr = [name, frac, seed, int(moving.sum()), nrim]
            rows.append(hr + ["CGAL refined fill", d[0] / diag, d[1] / diag, "", "", 0, 0.0])
            for method in ("willmore", "bilaplacian") + (() if quick else ("laplacian_of_h",)):
                secs, r = _timed(lambda: dgmesh.fair(Vr, Fr, mask=moving, method=method))
                d = patch_distances(V, F, hole, r.vertices, r.faces, region[r.face_origin])
                got[method + "_rf"] = d[0] / diag
                rows.append(hr + [method + " (CGAL refined fill)", d[0] / diag, d[1] / diag, float(r.energy[-1]),
                                  "yes" if r.linear_start else "", r.iterations, secs])
                data[f"{key}/{method}_rf"] = {"mean": d[0] / diag, "max": d[1] / diag, "E": float(r.energy[-1]),
                                              "iterations": r.iterations, "seconds": secs}
        groups.extend("b" * (len(rows) - len(groups)))
        # The Blender workflow: Fill (a fan, no inner vertex), then fair(refine=True): Liepa-style
        # refinement to the rim's edge lengths, then the flow.
        F2, fill = fan_fill(V, F, hole, inner)
        Vr, Fr, origin = refine_region(V, F2, fill)
        d = patch_distances(V, F, hole, Vr, Fr, fill[origin])
        hf = [name, frac, seed, len(Vr) - len(V), nrim]
        rows.append(hf + ["fan fill + refine_region", d[0] / diag, d[1] / diag, "", "", 0, 0.0])
        fan0 = d[0] / diag
        got["crease_original"] = rim_crease(V, F, hole)
        for method in ("willmore", "bilaplacian"):
            secs, r = _timed(lambda: dgmesh.fair(V, F2, faces=fill, refine=True, method=method))
            d = patch_distances(V, F, hole, r.vertices, r.faces, fill[r.face_origin])
            got[method + "_fan"] = d[0] / diag
            got["crease_" + method] = rim_crease(r.vertices, r.faces, fill[r.face_origin])
            rows.append(hf + [method + " (fan fill, refine=True)", d[0] / diag, d[1] / diag, float(r.energy[-1]),
                              "yes" if r.linear_start else "", r.iterations, secs])
            data[f"{key}/{method}_fan"] = {"mean": d[0] / diag, "max": d[1] / diag, "E": float(r.energy[-1]),
                                           "iterations": r.iterations, "seconds": secs,
                                           "rim_crease_deg": got["crease_" + method]}
            if method == "willmore":
                # The removed scan at the Willmore patch's own connectivity: its moving vertices
                # moved onto the removed surface. If that costs more energy than the result, the
                # flow did what it is asked and the scan is not a minimiser (closer costs energy).
                Vp = r.vertices.copy()
                Vp[r.moved] = closest_points(r.vertices[r.moved], V, F[hole])
                got["E_willmore"] = _region_energy(r.vertices, r.faces, r.moved)
                try:
                    got["E_original"] = _region_energy(Vp, r.faces, r.moved)
                except dgmesh.MeshError:  # two vertices projected onto one point (a crease of the scan)
                    got["E_original"] = float("nan")
                data[f"{key}/willmore_fan"].update(E_region=got["E_willmore"], E_original_projected=got["E_original"])
        groups.extend("c" * (len(rows) - len(groups)))
        data[f"{key}/original"] = {"E": e_orig, "rim_vertices": nrim, "rim_crease_deg": got["crease_original"]}
        got["_case"] = (name, frac, seed, nrim, int(inner.sum()), len(Vr) - len(V), fan0)
        wins.append((name, frac, got))
    scans = [w for w in wins if not w[0].startswith("icosphere")]
    ten = [w for w in scans if w[1] >= 0.1]

    def beats(group, other, ours="willmore"):
        pairs = [w[2] for w in group if other in w[2] and ours in w[2]]
        return sum(g[ours] < g[other] for g in pairs), len(pairs)

    lines = ["On our fill (the removed faces' connectivity):"]
    for ours, other, label in (("willmore", "bilaplacian", "the bilaplacian flow"),
                               ("willmore", "cgal_trf", "CGAL triangulate_refine_and_fair_hole"),
                               ("willmore", "cgal_fair", "CGAL fair on our fill"),
                               ("bilaplacian", "cgal_trf", "CGAL triangulate_refine_and_fair_hole (bilaplacian)"),
                               ("willmore_rf", "bilaplacian_rf", "the bilaplacian flow, both on CGAL's refined fill"),
                               ("willmore_rf", "cgal_trf", "CGAL triangulate_refine_and_fair_hole (same fill)"),
                               ("willmore_fan", "bilaplacian_fan", "the bilaplacian flow, both on a fan fill refined "
                                                                    "by fair(refine=True)"),
                               ("willmore_fan", "cgal_trf", "CGAL triangulate_refine_and_fair_hole (fan + refine)")):
        k_all, n_all = beats(wins, other, ours)
        k_sc, n_sc = beats(scans, other, ours)
        who = "Bilaplacian" if ours == "bilaplacian" else "Willmore"
        if n_all:
            if ours.endswith("_rf") and "On CGAL's refined fill (triangulate_and_refine_hole):" not in lines:
                lines.append("On CGAL's refined fill (triangulate_and_refine_hole):")
            if ours.endswith("_fan") and "On a fan fill refined by fair(refine=True):" not in lines:
                lines.append("On a fan fill refined by fair(refine=True):")
            lines.append(f"{who} closer than {label} on {k_all} of {n_all} holes ({k_sc} of {n_sc} scanned).")
            data.setdefault("summary", {})[f"{ours}_vs_{other}"] = [k_all, n_all, k_sc, n_sc]
    lines.append("Means:")
    for group, label in ((scans, "scanned holes"), (ten, "10% scanned holes")):
        if not group:
            continue
        means = []
        for m, lab in (("willmore", "Willmore"), ("bilaplacian", "bilaplacian"), ("laplacian_of_h", "Laplacian of H"),
                       ("cgal_trf", "CGAL refine+fair"), ("cgal_fair", "CGAL fair (our fill)"),
                       ("willmore_rf", "Willmore (CGAL refined fill)"),
                       ("bilaplacian_rf", "bilaplacian (CGAL refined fill)"),
                       ("willmore_fan", "Willmore (fan + refine)"), ("bilaplacian_fan", "bilaplacian (fan + refine)")):
            vals = [w[2][m] for w in group if m in w[2]]
            if len(vals) == len(group):
                means.append(f"{lab} {np.mean(vals):.4g}")
                data.setdefault("summary", {})[f"mean/{label}/{m}"] = float(np.mean(vals))
        lines.append(f"Mean distance over the {len(group)} {label}: " + ", ".join(means) + ".")
    # The same flow on three fills of the same holes: a flow whose result is a property of the rim
    # gives the same mean on each; the uniform bi-umbrella's fixed point depends on the
    # connectivity, and the removed faces' connectivity (fill a) carries the removed shape.
    # (the means over the scanned holes, from the loop above)
    mean = {m: v for key, v in data.get("summary", {}).items() if key.startswith("mean/scanned holes/")
            for m in [key.rsplit("/", 1)[1]]}
    fills = [(k, lab) for k, lab in (("", "our fill"), ("_rf", "CGAL's refined fill"), ("_fan", "fan + refine"))
             if "willmore" + k in mean and "bilaplacian" + k in mean]
    if len(fills) > 1:
        by_fill = [f"{lab} " + " / ".join(f"{mean[m + k]:.4g}" for k, _ in fills)
                   for m, lab in (("willmore", "Willmore"), ("bilaplacian", "bilaplacian"))]
        ratio = {m: np.mean([mean[m + k] for k, _ in fills[1:]]) / mean[m] for m in ("willmore", "bilaplacian")}
        lines.append("The fill's connectivity, mean over the scanned holes on " + " / ".join(l for _, l in fills)
                     + ": " + ", ".join(by_fill) + f". Mean on the user-like fills over the mean on our fill: "
                     f"Willmore {ratio['willmore']:.2f}, bilaplacian {ratio['bilaplacian']:.2f} (our fill keeps the "
                     "removed faces' own connectivity, which no user's fill has).")
    if cgal_tool(build=False) is None:
        lines.append("CGAL rows missing: g++ or libcgal-dev not installed (or, in quick mode, the tool not built yet).")
    summary = "\n".join(f"- {ln}" if not ln.endswith(":") else ln for ln in lines)
    # Headline: the Blender workflow fill (c), per hole. A hole whose interior is large for its
    # rim (removed vertices > rim^2 / 4; a disk on an even mesh has about rim^2 / 11) swallowed a
    # protrusion: the rim alone says nothing of it, so no fairing can bring it back.
    head_rows, n_ok, n_w, n_wb, n_wc, n_cmp, n_eo, n_eo_of = [], 0, 0, 0, 0, 0, 0, 0
    for name, frac, got in wins:
        cname, cfrac, cseed, nrim, ninner, nfill, dflat = got["_case"]
        if "willmore_fan" not in got:
            continue
        protr = ninner > nrim * nrim / 4
        cands = {"Willmore": got["willmore_fan"], "bilaplacian": got["bilaplacian_fan"]}
        if "cgal_trf" in got:
            cands["CGAL"] = got["cgal_trf"]
        best = min(cands, key=cands.get)
        scanned = not cname.startswith("icosphere")
        if scanned and not protr:
            n_ok += 1
            n_wb += got["willmore_fan"] < got["bilaplacian_fan"]
            if "cgal_trf" in got:
                n_cmp += 1
                n_wc += got["willmore_fan"] < got["cgal_trf"]
                n_w += best == "Willmore"
        note = (f"protrusion: rim {nrim} around {ninner} removed vertices; not restorable by fairing"
                if protr else "")
        head_rows.append([cname, cfrac, cseed, nrim, ninner, round(ninner / nrim**2, 3), nfill, dflat,
                          got["willmore_fan"],
                          got["bilaplacian_fan"], got.get("cgal_trf", ""), best,
                          "%.1f / %.1f / %.1f" % (got["crease_original"], got["crease_willmore"],
                                                  got["crease_bilaplacian"]),
                          "%.3g / %s" % (got["E_willmore"], "%.3g" % got["E_original"] if np.isfinite(got["E_original"])
                                         else "degenerate"), note])
        if scanned and not protr and np.isfinite(got["E_original"]):
            n_eo += got["E_original"] > got["E_willmore"]
            n_eo_of += 1
    n_scan = sum(1 for w in wins if not w[0].startswith("icosphere") and "willmore_fan" in w[2])
    sc = [w[2] for w in wins if not w[0].startswith("icosphere") and "willmore_fan" in w[2]]
    means = ", ".join(f"{lab} {np.mean([g[k] for g in sc]):.4g}" for k, lab in
                      (("willmore_fan", "Willmore"), ("bilaplacian_fan", "bilaplacian"), ("cgal_trf", "CGAL"))
                      if sc and all(k in g for g in sc))
    data.setdefault("summary", {})["workflow"] = {"scanned": n_scan, "restorable": n_ok,
                                                  "original_energy_higher": n_eo,
                                                  "willmore_beats_bilaplacian": n_wb,
                                                  "willmore_beats_cgal": n_wc, "compared_with_cgal": n_cmp,
                                                  "willmore_best": n_w}
    cr = [w[2] for w in wins if "crease_willmore" in w[2] and not w[0].startswith("icosphere")]
    crease_note = ""
    if cr:
        sharper = sum(g["crease_bilaplacian"] > g["crease_willmore"] for g in cr)
        dev = {m: np.mean([abs(g["crease_" + m] - g["crease_original"]) for g in cr]) for m in ("willmore", "bilaplacian")}
        crease_note = (f"Rim crease: the mean dihedral angle across the rim's edges, between the patch and the surface "
                       f"around it ('scan': between the removed faces and the kept ones). On {sharper} of {len(cr)} "
                       f"scanned holes the bilaplacian (uniform bi-umbrella) patch meets the surface with a sharper "
                       f"crease than Willmore's; mean deviation from the scan's own bend there: Willmore "
                       f"{dev['willmore']:.2f} deg, bilaplacian {dev['bilaplacian']:.2f} deg. A patch that meets the "
                       f"rim with a crease lies flatter inside, which is closer only where the original is flatter "
                       f"than a smooth continuation of its rim.")
        data.setdefault("summary", {})["rim_crease"] = {"bilaplacian_sharper": sharper, "holes": len(cr),
                                                        "mean_deviation_deg": dev}
    headline = (f"**Blender workflow** (delete, Fill: a fan over the rim, select, Fair with Refine Fill = "
                f"`dgmesh.fair(V, F, faces=fill, refine=True)`, which re-triangulates the fan by Liepa's minimum-weight "
                f"triangulation of the rim before refining it): the fill knows nothing of the removed shape. "
                f"On the {n_ok} scanned holes that fairing can restore (of {n_scan}; the others swallowed a "
                f"protrusion: removed vertices > rim^2 / 4, where a disk on an even mesh has about rim^2 / 11), "
                f"Willmore is closer than the bilaplacian flow on {n_wb} of {n_ok}, closer than CGAL "
                f"triangulate_refine_and_fair_hole on {n_wc} of {n_cmp}, closest of the three on {n_w} of {n_cmp}. "
                f"Mean distance over all {n_scan} scanned holes: {means}. On {n_eo} of {n_eo_of} restorable holes "
                f"the removed scan itself, put on the Willmore patch's connectivity (its moving vertices moved "
                f"onto the removed surface; 'degenerate' where two of them landed on one point), has a higher discrete Willmore energy than the Willmore result "
                f"(column 'E'): there the flow lowers the energy it is asked to, and a patch closer to the scan "
                f"would cost energy (the scan's noise is part of that cost).\n\n"
                + table(["mesh", "area", "seed", "rim", "removed vertices", "removed / rim^2", "fill vertices", "refined fan (unfaired)",
                         "Willmore", "bilaplacian", "CGAL refine+fair", "closest",
                         "rim crease deg: scan / Willmore / bilaplacian",
                         "E: Willmore / scan on its mesh", "note"], head_rows)
                + "\n\n" + crease_note)
    sec = {g: [r for r, gg in zip(rows, groups) if gg == g] for g in "abc"}
    cols = ["mesh", "area", "seed", "moving vertices", "rim", "method", "mean dist", "max dist", "E",
            "linear start", "iterations", "s"]
    md = ("Remove a geodesic disk of the given area fraction around a vertex (random for the scans), restore "
          "it, and measure the symmetric distance restored patch <-> removed original surface over the bbox "
          "diagonal (mean: the two directions' means over surface area, Metro's mean distance, so that how "
          "finely a patch is triangulated does not weight it; max in the detail tables). Flows: `dgmesh.fair` semi-implicit, tolerance 1e-4; "
          "Willmore starts from the linearised minimiser U0^2 P = 0 when it lowers the energy ('linear start'). "
          "Reference, measured on the same holes with CGAL 5.5 (bench/tools/cgal_fair_hole.cpp, built on demand, "
          "skipped in quick mode unless already built): `triangulate_refine_and_fair_hole` on the mesh with the "
          "hole cut out (its own triangulation and refinement, default cotangent bi-Laplacian fairing); its "
          "times include the tool's start and OFF I/O. 'rim': vertices on the hole's border. "
          "E: discrete Willmore energy (sum H^2 A) of the moving vertices and their first fixed ring.\n\n"
          + headline + "\n\n"
          "Summary over all fills:\n" + summary + "\n\n"
          "(c) Workflow fill, details ('moving vertices': the refinement's new vertices):\n\n"
          + table(cols, sec["c"]) + "\n\n"
          "(a) The bench's own fill: the removed vertices kept with the original connectivity, interior at the "
          "membrane solution. That connectivity leaks the removed shape, which favours the uniform bilaplacian "
          "flow; also CGAL `fair` on this fill.\n\n"
          + table(cols, sec["a"]) + "\n\n"
          + ("(b) CGAL's refined flat fill (`triangulate_and_refine_hole`), faired by our flows: the same "
             "connectivity CGAL's own fairing uses, so it compares the fairing alone.\n\n"
             + table(cols, sec["b"]) + "\n\n" if sec["b"] else "")
          + "Reproduce: `/usr/bin/python3 bench/run.py fair_restore`" + (" (this run: --quick)" if quick else ""))
    return {"markdown": md, "data": data}


def _mean_curvature_rgb(V, F, limit):
    from dgmesh import colors
    H = dgmesh.curvature(V, F).mean
    return colors.diverging(H, limit=limit)[:, :3][F].mean(1)


def _local_view(Vs, F, faces, centre, normal, radius):
    """Faces within `radius` of `centre`, every panel rotated so that `normal` points to -Y (the
    camera looks along +Y)."""
    z = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(z, normal)
    x /= np.linalg.norm(x)
    up = np.cross(normal, x)
    R = np.stack([x, -normal, up])  # rows: new x, y, z
    out = []
    for V, Ff in zip(Vs, faces):
        Fk = Ff[np.linalg.norm(V[Ff].mean(1) - centre, axis=1) < radius]
        used, Fc = np.unique(Fk, return_inverse=True)  # compact: the framing uses every vertex
        out.append(((V[used] - centre) @ R.T, Fc.reshape(-1, 3).astype(np.int32)))
    return out


def fair_renders(quick):
    """Thesis fig. 3.6-3.7 style: original, flat fill, bilaplacian, Willmore side by side, coloured by
    mean curvature (one colour scale per row), rendered by Blender."""
    from bench.workloads.crest import _render
    size = (300, 260) if not quick else (150, 130)
    samples = 16 if not quick else 4
    prefix = "fair_" if not quick else "quick_fair_"
    names, data = [], {}
    cases = [("sphere", 0.3, 0)] if quick else [("sphere", 0.3, 0), ("bunny00", 0.1, 0), ("camel", 0.05, 1)]
    for name, frac, seed in cases:
        if name == "sphere":
            V, F, hole, inner = _sphere_hole(frac)
        else:
            V, F = cgal_mesh(name)
            _c, (hole, inner) = find_hole(V, F, frac, seed)
        V0 = membrane_fill(V, F, hole, inner)
        rb = dgmesh.fair(V0, F, mask=inner, method="bilaplacian")
        rw = dgmesh.fair(V0, F, mask=inner, method="willmore")
        Vs = [V, V0, rb.vertices, rw.vertices]
        Fs = [F, F, rb.faces, rw.faces]
        hv = np.unique(F[hole])
        centre = V[hv].mean(0)
        fn = np.cross(V[F[hole, 1]] - V[F[hole, 0]], V[F[hole, 2]] - V[F[hole, 0]]).sum(0)
        fn /= np.linalg.norm(fn)
        radius = 1.25 * np.linalg.norm(V[hv] - centre, axis=1).max()
        local = _local_view(Vs, Fs, Fs, centre, fn, radius)
        # One scale for the row: the restored patches' 95th percentile of |H| (the scans' own
        # noise would wash the patches out).
        from dgmesh import colors
        limit = max(colors.symmetric_limit(dgmesh.curvature(r.vertices, r.faces).mean[r.moved])
                    for r in (rb, rw))
        panels = [{"V": Vl, "F": Fl, "colors": _mean_curvature_rgb(Vl, Fl, limit)} for Vl, Fl in local]
        fname = f"{prefix}restore_{name}.png"
        _render(fname, panels, up="Z", view=(0.0, -1.0, 0.0), gap=0.08, size=(4 * size[0], size[1]),
                samples=samples)
        names.append((fname, f"{name}, {int(frac * 100)}% hole ({int(inner.sum())} moving vertices): original, "
                             "flat fill, bilaplacian, Willmore (left to right), mean curvature blue < 0 < red, "
                             f"|H| scale {limit:.3g}"))
        data[name] = {"limit": float(limit)}
    md = ("Hole restoration as in thesis fig. 3.6-3.7, faces near the hole, coloured by mean curvature "
          "(`dgmesh.curvature`, diverging palette, one scale per row: the restored patches' 95th percentile of |H|).\n\n"
          + "\n\n".join(f"![{t}](images/{n})\n\n{t}" for n, t in names)
          + "\n\nReproduce: `/usr/bin/python3 bench/run.py fair_renders`")
    return {"markdown": md, "data": data}


def _cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _damaged_region_speed(data):
    """Issue 30's speed case: armadillo subdivided 1-to-4 (104002 vertices), 6% of its vertices
    (6240) around the most saddle-like vertex flattened, restored by each method with its defaults:
    wall and CPU seconds (all threads), iterations, and where the Willmore flow's energy settles."""
    V, F = cgal_mesh("armadillo")
    V, F = dgmesh.shapes.subdivide_linear(V, F)
    patch = vertex_ball(V, F, region_centre(V, F, "saddle"), int(0.06 * len(V)))
    W = damage(V, F, patch, "flat")
    diag = bbox_diagonal(V)
    region, _rim = _region_of(F, patch)
    rows = []
    for method in ("bilaplacian", "willmore", "hinge"):
        c0 = _cpu_seconds()
        secs, r = _timed(lambda: dgmesh.fair(W, F, mask=patch, method=method))
        cpu = _cpu_seconds() - c0
        dist = patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0] / diag
        rows.append([method, len(V), int(patch.sum()), r.iterations, str(bool(r.converged)), float(r.energy[0]),
                     float(r.energy[-1]), dist, secs, cpu, secs / max(r.iterations, 1)])
        data[f"damaged_6pct_104K/{method}"] = {"seconds": secs, "cpu_seconds": cpu, "iterations": r.iterations,
                                               "converged": bool(r.converged), "E0": float(r.energy[0]),
                                               "E": float(r.energy[-1]), "mean_distance_over_diag": dist}
        if method == "willmore":
            E = np.asarray(r.energy)
            reach = {}
            for frac in (0.1, 0.01, 0.001):  # first iteration within frac of the last energy's drop
                gap = (E - E[-1]) / (E[0] - E[-1])
                reach[frac] = int(np.flatnonzero(gap <= frac)[0])
            data["damaged_6pct_104K/willmore_energy"] = [float(x) for x in E]
            data["damaged_6pct_104K/willmore_reach"] = {str(k): v for k, v in reach.items()}
    wr = data["damaged_6pct_104K/willmore_reach"]
    E = data["damaged_6pct_104K/willmore_energy"]
    marks = [k for k in (1, 2, 5, 10, 20, 50, 100, 200, len(E) - 1) if k < len(E)]
    md = ("\n\n### Damaged region on a 104K-vertex scan (issue 30's target: < 1 s)\n\n"
          "armadillo (CGAL data) subdivided 1-to-4 by `dgmesh.shapes.subdivide_linear`, 6% of its vertices "
          "around the most saddle-like vertex (`region_centre(..., 'saddle')`) flattened onto the plane of the "
          f"rim (`damage(..., 'flat')`), `dgmesh.fair(W, F, mask=patch, method=...)` with defaults; load average "
          f"{os.getloadavg()[0]:.1f} after the runs ({dgmesh.num_threads()} threads). CPU: the process's user + "
          "system seconds over all threads. Distance: mean distance to the original region over the bbox "
          "diagonal (as fair_repair).\n\n"
          + table(["method", "vertices", "region vertices", "iterations", "converged", "E input", "E output",
                   "distance / diag", "wall s", "CPU s", "wall s / iteration"], rows)
          + "\n\nWillmore flow energy (sum H^2 A over the region and its first ring) by iteration: "
          + ", ".join(f"{k}: {E[k]:.5g}" for k in marks)
          + f". It is within 10% / 1% / 0.1% of its drop to the last iterate after {wr['0.1']} / {wr['0.01']} / "
          f"{wr['0.001']} iterations.")
    return md


def fair_speed(quick):
    """Speed: a ~5K-vertex hole patch to convergence; a closed 10K-vertex mesh with one
    subdivision level; explicit vs semi-implicit; a 6% damaged region of a 104K-vertex scan by each
    method (issue 30)."""
    rows, data = [], {}
    V, F = cgal_mesh("bunny00")
    _c, (hole, inner) = find_hole(V, F, 0.14, 0)
    V0 = membrane_fill(V, F, hole, inner)
    # Closed mesh, thesis fig. 3.1 style: start from a 2.5K-vertex mesh, one subdivision level.
    Vs, Fs = dgmesh.shapes.icosphere(4)
    Vs = Vs * np.array([2.0, 1.0, 0.7])
    cases = [("hole patch bunny00", V0, F, dict(mask=inner)),
             ("closed ellipsoid 2.5K -> 10K (1 subdivision)", Vs, Fs, dict(subdivisions=1))]
    for label, VV, FF, kw in cases:
        for scheme in ("semi_implicit", "explicit"):
            budget = 20.0 if quick else 120.0
            secs, r = _timed(lambda: dgmesh.fair(VV, FF, scheme=scheme, max_seconds=budget,
                                                 max_iterations=100000 if scheme == "explicit" else 300, **kw))
            k = r.level_iterations[0] if len(r.level_iterations) > 1 else None
            levels = "" if k is None else f"{r.energy[k]:.4g} -> {r.energy[min(k + 1, len(r.energy) - 1)]:.4g}"
            rows.append([label, scheme, int(r.moved.sum()), len(r.vertices), r.iterations, str(r.converged),
                         float(r.energy[0]), levels, float(r.energy[-1]), secs])
            data[f"{label}/{scheme}"] = {"iterations": r.iterations, "converged": r.converged, "seconds": secs,
                                         "E0": float(r.energy[0]), "E": float(r.energy[-1])}
    md = (f"Threads: {dgmesh.num_threads()}. Explicit runs stop at a wall-clock budget "
          f"({'20' if quick else '120'} s) when they do not converge. Targets: hole patch of 5K vertices <= 2 s, "
          "closed 10K-vertex mesh with one subdivision <= 10 s. 'E level 0' = the energy where the first level "
          "ended and after the first step on the subdivided mesh: the linear 1-to-4 subdivision raises the "
          "discrete energy (flat facets), so a run whose budget ends early in its subdivided level reports an "
          "output energy above its input.\n\n"
          + table(["case", "scheme", "moving vertices", "output vertices", "iterations", "converged", "E input",
                   "E level 0", "E output", "s"], rows)
          + _damaged_region_speed(data)
          + "\n\nReproduce: `/usr/bin/python3 bench/run.py fair_speed`")
    return {"markdown": md, "data": data}


def fair_stall(quick):
    """Issue 30's experiment: on CGAL scans, the 6% of the vertices geodesically nearest to a tip
    (the vertex farthest from the centroid) flattened onto the least-squares plane of their rim, the
    faces touching them selected (the rim fixed), restored by each method with defaults; mean
    distance to the original region (patch_distances) over the bbox diagonal."""
    names = ["hand", "elephant"] if quick else ["hand", "elephant", "femur", "mushroom", "homer", "bull", "camel"]
    _PER_FACE[0] = 1 if quick else 3
    rows, data = [], {}
    methods = ["damaged", "willmore", "bilaplacian", "cgal_fair", "smooth"]
    for name in names:
        V, F = cgal_mesh(name)
        patch = vertex_ball(V, F, region_centre(V, F, "tip"), int(0.06 * len(V)))
        res = repair_case(V, F, patch, "flat", cgal=cgal_tool(build=not quick) is not None)
        w = res["willmore"][2]
        rows.append([name, len(V), int(patch.sum())] + [res[m][0] if m in res else "" for m in methods]
                    + [w["E0"], w["E"], w["iterations"], w["max_move"], str(w["converged"])])
        data[name] = {m: res[m][0] for m in methods if m in res} | {"willmore_info": w}
    md = ("Issue 30's experiment: on each scan the 6% of its vertices nearest (geodesically) to a tip "
          "(the vertex farthest from the centroid) are projected onto the least-squares plane of their "
          "rim; the faces touching them are the region (its border fixed); each method restores it with "
          "its defaults. Distances: mean distance restored region <-> original region (Metro-style, "
          "both ways, over area) / bbox diagonal. 'smooth': Blender-like Smooth Vertices (500 x factor 0.5). "
          "Willmore's energy before/after, iterations and largest vertex move (/ diagonal) follow.\n\n"
          + table(["mesh", "vertices", "region vertices", "flat (damaged)", "Willmore", "bilaplacian", "CGAL fair",
                   "smooth", "W: E start", "W: E end", "W: iterations", "W: max move", "W: converged"], rows)
          + "\n\nReproduce: `/usr/bin/python3 bench/run.py fair_stall`")
    return {"markdown": md, "data": data}


def fair_drift(quick):
    """Tangential drift (thesis eq. 3.8, 3.10) on and off: a 2:1:1 ellipsoid (icosphere level 3)
    whose vertices are jittered in their tangent planes (Gaussian, 0.15 and 0.25 mean edge lengths),
    faired whole by the default (semi-implicit) Willmore flow: final energy (the round sphere: 12.51
    at this resolution, 4 pi = 12.57), smallest angle, iterations, stall."""
    rows, data = [], {}
    V0, F = dgmesh.shapes.icosphere(3)
    V0 = V0 * np.array([2.0, 1.0, 1.0])
    h = float(np.linalg.norm(V0[F[:, 0]] - V0[F[:, 1]], axis=1).mean())
    N = dgmesh.curvature(V0, F).normals
    for amp in ([0.15] if quick else [0.15, 0.25]):
        for seed in ([0] if quick else [0, 1, 2]):
            J = np.random.default_rng(seed).normal(0, amp * h, V0.shape)
            J -= (J * N).sum(1)[:, None] * N
            V = V0 + J
            for tang in (True, False):
                secs, r = _timed(lambda: dgmesh.fair(V, F, tangential=tang))
                rows.append([amp, seed, "on" if tang else "off", float(r.energy[0]), float(r.energy[-1]),
                             min_angle_deg(V, F), min_angle_deg(r.vertices, r.faces), r.iterations,
                             str(r.converged), r.stall.name, secs])
                data[f"{amp}/{seed}/{'on' if tang else 'off'}"] = {"E": float(r.energy[-1]),
                                                                   "min_angle": rows[-1][6]}
    on = [r for r in rows if r[2] == "on"]
    off = [r for r in rows if r[2] == "off"]
    lower = sum(a[4] < b[4] - 1e-3 for a, b in zip(on, off))
    higher = sum(a[4] > b[4] + 1e-3 for a, b in zip(on, off))
    sphere = sum(r[4] < 12.6 for r in on), sum(r[4] < 12.6 for r in off)
    md = ("Tangential drift (eq. 3.8, 3.10) on/off, `dgmesh.fair(V, F, tangential=...)` defaults, on a 2:1:1 "
          "ellipsoid (icosphere level 3, 642 vertices) jittered in the tangent planes by Gaussian offsets of the "
          "given size in mean edge lengths. The Willmore minimiser is the round sphere (discrete energy 12.51 "
          f"here). With the drift the energy ended lower on {lower} of {len(on)} cases, higher on {higher}; it "
          f"reached the sphere (E < 12.6) on {sphere[0]} of {len(on)} with the drift, {sphere[1]} of {len(off)} "
          "without.\n\n"
          + table(["jitter (edges)", "seed", "drift", "E input", "E output", "min angle in", "min angle out",
                   "iterations", "converged", "stall", "s"], rows)
          + "\n\nReproduce: `/usr/bin/python3 bench/run.py fair_drift`")
    return {"markdown": md, "data": data}


_REPAIR_MESHES = ["hand", "elephant", "femur", "homer", "bull"]


def _verdict(ours, peer, tie=0.05):
    """won / tied / lost of distance `ours` against `peer` (tied: within `tie` of the smaller)."""
    if abs(ours - peer) <= tie * min(ours, peer):
        return "tied"
    return "won" if ours < peer else "lost"


def fair_repair(quick):
    """Issue 30: damaged regions that keep their vertices (flattened, dented, noise-filled) on CGAL
    scans, at 2/6/12% of the vertices around a tip, a saddle and a flat-ish area; restored by
    method 'hinge' (the edge-based Willmore energy from the bilaplacian start; also from the cotangent
    start on the damaged input's metric, start_weights='cotangent'), the Willmore flow
    (the default: linear start and restart), the thesis's Willmore flow from the input (linear_start
    off), the bilaplacian flow, CGAL fair and Blender-like smoothing; mean distance to the original
    region (patch_distances) over the bbox diagonal; won/tied/lost of the default and of hinge per peer."""
    _PER_FACE[0] = 1
    meshes = ["elephant", "bull"] if quick else _REPAIR_MESHES
    wheres = ["tip"] if quick else ["tip", "saddle", "flat"]
    kinds = ["flat", "dent", "noise"]
    fracs = [0.06] if quick else [0.02, 0.06, 0.12]
    methods = ["hinge", "hinge:cot", "willmore", "willmore:thesis", "bilaplacian"]
    kw = {"willmore:thesis": {"method": "willmore", "linear_start": False},
          "hinge:cot": {"method": "hinge", "start_weights": "cotangent"}}
    peers = ["damaged", "hinge:cot", "willmore", "willmore:thesis", "bilaplacian", "cgal_fair", "smooth"]
    w_peers = ["damaged", "hinge", "bilaplacian", "cgal_fair", "smooth"]  # the default against these
    use_cgal = cgal_tool(build=not quick) is not None
    rows, data, tally = [], {}, {p: {"won": 0, "tied": 0, "lost": 0} for p in peers}
    w_tally = {p: {"won": 0, "tied": 0, "lost": 0} for p in w_peers}
    by_kind, cot_vs, w_by_kind = {}, {}, {}
    restarted = stalled = h_stalled = 0
    skipped = []
    t_all = time.perf_counter()
    for name in meshes:
        V, F = cgal_mesh(name)
        for where in wheres:
            centre = region_centre(V, F, where)
            for frac in fracs:
                patch = vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
                for kind in kinds:
                    try:
                        res = repair_case(V, F, patch, kind, methods=methods, cgal=use_cgal, smooth=True, **kw)
                    except dgmesh.MeshError as exc:  # e.g. a ball pinched at a vertex: not a disk region
                        skipped.append(f"{name}/{where}/{frac}/{kind}: {exc}")
                        continue
                    w, h = res["willmore"], res["hinge"]
                    restarted += w[2]["restarted"]
                    stalled += w[2]["status"] != "none"
                    h_stalled += h[2]["status"] != "none"
                    row = [name, where, frac, kind, int(patch.sum())] + [res[m][0] if m in res else ""
                                                                          for m in ["hinge"] + peers]
                    row += [h[2]["status"], w[2]["status"], "yes" if w[2]["restarted"] else "", h[1], w[1]]
                    rows.append(row)
                    data[f"{name}/{where}/{frac}/{kind}"] = {m: res[m][0] for m in res}
                    for p in peers:
                        if p in res:
                            v = _verdict(h[0], res[p][0])
                            tally[p][v] += 1
                            by_kind.setdefault((kind, p), {"won": 0, "tied": 0, "lost": 0})[v] += 1
                    for p in w_peers:
                        if p in res:
                            v = _verdict(w[0], res[p][0])
                            w_tally[p][v] += 1
                            w_by_kind.setdefault((kind, p), {"won": 0, "tied": 0, "lost": 0})[v] += 1
                    for p in ["hinge", "cgal_fair", "bilaplacian"]:  # the cotangent start against its peers
                        if p in res:
                            v = _verdict(res["hinge:cot"][0], res[p][0])
                            cot_vs.setdefault((kind, p), {"won": 0, "tied": 0, "lost": 0})[v] += 1
    secs = time.perf_counter() - t_all
    names = {"hinge": "hinge", "hinge:cot": "hinge, cotangent start", "willmore": "Willmore flow (default)", "damaged": "the damaged input",
             "willmore:thesis": "Willmore, thesis flow from the input",
             "bilaplacian": "bilaplacian", "cgal_fair": "CGAL fair", "smooth": "Blender-like smoothing"}
    w_head = table(["peer", "won", "tied", "lost"],
                   [[names[p], w_tally[p]["won"], w_tally[p]["tied"], w_tally[p]["lost"]] for p in w_peers if sum(w_tally[p].values())])
    w_per_kind = table(["damage", "peer", "won", "tied", "lost"],
                       [[k, names[p], v["won"], v["tied"], v["lost"]] for (k, p), v in sorted(w_by_kind.items())])
    head = table(["peer", "won", "tied", "lost"],
                 [[names[p], tally[p]["won"], tally[p]["tied"], tally[p]["lost"]] for p in peers if sum(tally[p].values())])
    per_kind = table(["damage", "peer", "won", "tied", "lost"],
                     [[k, names[p], v["won"], v["tied"], v["lost"]] for (k, p), v in sorted(by_kind.items())])
    cot_table = table(["damage", "peer", "won", "tied", "lost"],
                      [[k, names[p], v["won"], v["tied"], v["lost"]] for (k, p), v in sorted(cot_vs.items())])
    mean = {m: float(np.mean([d[m] for d in data.values() if m in d])) for m in ["hinge"] + peers}
    by_where = {w: {m: float(np.mean([d[m] for k, d in data.items() if k.split("/")[1] == w and m in d]))
                    for m in ["hinge", "hinge:cot", "willmore", "bilaplacian", "cgal_fair"]} for w in wheres}
    data["summary"] = {"tally": tally, "default_tally": w_tally, "default_by_kind": {f"{k}/{p}": v for (k, p), v in w_by_kind.items()},
                       "cotangent_start_tally": {f"{k}/{p}": v for (k, p), v in cot_vs.items()}, "mean": mean, "by_where": by_where, "cases": len(rows),
                       "restarted": restarted, "stalled": stalled, "hinge_stalled": h_stalled, "seconds": secs,
                       "skipped": skipped}
    md = ("Damaged regions that keep their vertices (issue 30). On each CGAL scan, the vertices geodesically "
          "nearest to a tip (farthest from the centroid), a saddle (most negative Gaussian curvature, two-ring "
          "average) or a flat-ish area (smallest |k1|+|k2|), 2/6/12% of the vertices, are damaged: 'flat' "
          "(projected onto the rim's least-squares plane), 'dent' (each vertex pushed along its own inward normal by "
          "0.5 x the local feature size, the region's median inner medial-ball radius capped by its geodesic radius, "
          "times a smooth bump of the geodesic distance to the rim; session 25, before: a bump along the region's "
          "mean normal, a near no-op at tips), 'noise' (flattened, then +-0.5 mean edge lengths of uniform noise along the "
          "plane's normal). The faces touching the region are faired, the rim fixed. Distance: mean distance "
          "restored region <-> original region (Metro-style, both ways, area-weighted, 1 sample per face) / "
          "bbox diagonal. Methods: `dgmesh.fair` with method='hinge' (the edge-based Willmore energy, "
          "Levenberg-Marquardt from the bilaplacian start U0^2 P = 0, uniform weights), 'hinge, cotangent start' "
          "(the same from the cotangent bi-Laplacian L M^-1 L P = 0 with the damaged input's cotangent weights and "
          "mixed areas, start_weights='cotangent': the system CGAL fair solves), method='willmore' (the default flow, linear start "
          "and restart), the same with linear_start=False (the thesis's flow from the input), method='bilaplacian'; CGAL 5.5 `Polygon_mesh_processing::fair` of "
          "the region's vertices (bench/tools/cgal_fair_hole.cpp); 'smooth': 500 x Smooth Vertices factor 0.5 "
          "(uniform umbrella, numpy). Verdicts: 'tied' within 5%.\n\nThe default (Willmore flow) against each peer:\n\n"
          + w_head + "\n\nBy damage:\n\n" + w_per_kind + "\n\nhinge against each peer:\n\n"
          + head + "\n\nBy damage:\n\n" + per_kind
          + "\n\nhinge, cotangent start against its peers, by damage:\n\n" + cot_table
          + "\n\nMean distance over all cases: " + ", ".join(f"{names.get(m, m)} {v:.4g}" for m, v in mean.items())
          + ". By place (hinge / hinge, cotangent start / Willmore / bilaplacian / CGAL fair): "
          + "; ".join(f"{w} " + " / ".join(f"{v:.4g}" for v in by_where[w].values()) for w in wheres)
          + f". Willmore restarted from the linear start on {restarted} of {len(rows)} cases; reported a stall on "
          f"{stalled} (hinge: {h_stalled}). Run time {secs:.0f} s (under load)."
          + (f" Skipped (dgmesh.fair refused the region): {'; '.join(skipped)}." if skipped else "") + "\n\n"
          + table(["mesh", "where", "fraction", "damage", "region vertices", "hinge", "damaged", "hinge, cotangent start",
                   "Willmore", "Willmore (thesis, from input)", "bilaplacian", "CGAL fair", "smooth",
                   "hinge stall", "W stall", "W restarted", "hinge s", "W s"], rows)
          + "\n\nReproduce: `/usr/bin/python3 bench/run.py fair_repair`" + (" (this run: --quick)" if quick else ""))
    return {"markdown": md, "data": data}


WORKLOADS = {"fair_energy": fair_energy, "fair_restore": fair_restore, "fair_speed": fair_speed,
             "fair_renders": fair_renders, "fair_stall": fair_stall, "fair_repair": fair_repair,
             "fair_drift": fair_drift}


# ---------------------------------------------------------------------------------------------
# Damaged regions (issue 30): the region keeps its vertices, their positions are damaged
# ---------------------------------------------------------------------------------------------

def _edge_graph(V, F):
    """The mesh's edges as a weighted graph: vertex v's neighbours are dst[start[v]:start[v + 1]], at
    edge lengths ww[...]."""
    E = _edges(F)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    src = np.concatenate([E[:, 0], E[:, 1]])
    order = np.argsort(src, kind="stable")
    src, dst, ww = src[order], np.concatenate([E[:, 1], E[:, 0]])[order], np.concatenate([w, w])[order]
    return np.searchsorted(src, np.arange(len(V) + 1)), dst, ww


def vertex_ball(V, F, centre, count):
    """Mask of the `count` vertices geodesically (Dijkstra over edges) nearest to `centre`."""
    n = len(V)
    start, dst, ww = _edge_graph(V, F)
    dist = np.full(n, np.inf)
    dist[centre] = 0.0
    heap, done, got = [(0.0, centre)], np.zeros(n, dtype=bool), 0
    while heap and got < count:
        d, v = heapq.heappop(heap)
        if done[v]:
            continue
        done[v] = True
        got += 1
        for j in range(start[v], start[v + 1]):
            u, nd = dst[j], d + ww[j]
            if nd < dist[u]:
                dist[u] = nd
                heapq.heappush(heap, (nd, u))
    return done


def _region_of(F, patch):
    """Faces touching the patch (the selection a user makes in Edit mode) and the rim: the region's
    vertices that are not in the patch (its fixed border)."""
    region = patch[F].any(axis=1)
    rim = np.zeros(len(patch), dtype=bool)
    rim[F[region].ravel()] = True
    rim &= ~patch
    return region, rim


def _plane(P):
    """Least-squares plane through points P: (centroid, unit normal)."""
    c = P.mean(0)
    return c, np.linalg.svd(P - c)[2][2]


def _vertex_normals(V, F):
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    return N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)


def damage(V, F, patch, kind, seed=0):
    """The patch's vertices damaged in place (same connectivity): "flat" (projected onto the
    least-squares plane of the rim), "dent" (each vertex pushed along its own inward normal by
    DENT_DEPTH x the local feature size times a smooth bump of its geodesic distance to the rim,
    see _dent), "noise" (flattened, then each vertex displaced along the plane's normal by a uniform
    amount within +-0.5 mean edge lengths) or "dent_axis" (sessions 19-24's dent: along the patch's
    mean normal by a bump of the straight distance to the rim's centroid, depth 0.3 of the rim's
    radius; at tips it mostly slides the surface along itself, kept to reproduce those notes).
    Returns the damaged vertices."""
    _region, rim = _region_of(F, patch)
    W = V.copy()
    if kind in ("flat", "noise"):
        c, nrm = _plane(V[rim])
        W[patch] -= np.outer((V[patch] - c) @ nrm, nrm)
        if kind == "noise":
            h = float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean())
            W[patch] += np.outer(np.random.default_rng(seed).uniform(-0.5, 0.5, int(patch.sum())) * h, nrm)
    elif kind == "dent":
        W[patch] -= _dent(V, F, patch, rim)
    elif kind == "dent_axis":
        N = _vertex_normals(V, F)
        nrm = N[patch].mean(0)
        nrm /= np.linalg.norm(nrm)
        c = V[rim].mean(0)
        r = np.linalg.norm(V[patch] - c, axis=1)
        R = np.linalg.norm(V[rim] - c, axis=1).mean()
        bump = np.clip(1 - (r / R) ** 2, 0, 1) ** 2
        W[patch] -= np.outer(0.3 * R * bump, nrm)
    else:
        raise ValueError(kind)
    return W


DENT_DEPTH = 0.5  # of the local feature size (_dent)


def _distance_to(V, F, sources, allowed):
    """Dijkstra distance over edges from the `sources` mask, walking only through `allowed` vertices."""
    n = len(V)
    start, dst, ww = _edge_graph(V, F)
    dist = np.full(n, np.inf)
    dist[sources] = 0.0
    heap = [(0.0, int(v)) for v in np.flatnonzero(sources)]
    heapq.heapify(heap)
    while heap:
        d, v = heapq.heappop(heap)
        if d > dist[v]:
            continue
        for j in range(start[v], start[v + 1]):
            u, nd = dst[j], d + ww[j]
            if allowed[u] and nd < dist[u]:
                dist[u] = nd
                heapq.heappush(heap, (nd, u))
    return dist


def inner_feature_size(V, N, idx):
    """Inner medial-ball radius at vertices `idx` (shrinking-ball estimate over the vertices as
    samples): the largest ball tangent at p on the inward side (-N) with no vertex inside,
    min over q with n.(q - p) > 0 of |q - p|^2 / (2 n.(q - p)), n = -N(p)."""
    out = np.empty(len(idx))
    for k, i in enumerate(idx):
        d = V - V[i]
        dot, l2 = d @ -N[i], (d * d).sum(1)
        ok = dot > 1e-12 * np.sqrt(l2)
        ok[i] = False
        out[k] = np.min(l2[ok] / (2 * dot[ok])) if ok.any() else np.inf
    return out


def _dent(V, F, patch, rim, samples=200):
    """Displacement of the patch's vertices for the "dent" damage (issue 30: pushed inwards by a
    fraction of the local feature size): vertex v moves along its own inward normal by
    DENT_DEPTH * lfs * b(s), s = g(v) / max g (g the geodesic distance to the rim inside the patch),
    b(s) = (1 - (1 - s)^2)^2 (0 with zero slope at the rim, 1 with zero slope at the deepest vertex).
    lfs: the median inner medial-ball radius (inner_feature_size) over up to `samples` patch vertices
    of the original surface, capped by max g (a dent, not a pit); normals outward by the sign of the
    enclosed volume."""
    N = _vertex_normals(V, F)
    vol = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum()
    N = N if vol >= 0 else -N
    g = _distance_to(V, F, rim, patch | rim)[patch]
    gmax = float(g[np.isfinite(g)].max())
    s = np.clip(np.where(np.isfinite(g), g, gmax) / gmax, 0, 1)
    idx = np.flatnonzero(patch)
    sub = np.random.default_rng(0).choice(idx, min(samples, len(idx)), replace=False)
    lfs = min(float(np.median(inner_feature_size(V, N, sub))), gmax)
    return (DENT_DEPTH * lfs * (1 - (1 - s) ** 2) ** 2)[:, None] * N[patch]


def region_centre(V, F, where, seed=0):
    """A vertex on a "tip" (farthest from the centroid: ear, nose, limb ends), a "saddle" (most
    negative Gaussian curvature, averaged over two rings) or a "flat" (smallest |k1|+|k2| averaged
    over two rings, away from the mesh boundary) area; `seed` picks among the 20 best."""
    if where == "tip":
        score = -np.linalg.norm(V - V.mean(0), axis=1)
    else:
        c = dgmesh.curvature(V, F)
        H, K = c.mean, c.gaussian
        E = _edges(F)
        val = K if where == "saddle" else np.abs(H) + np.sqrt(np.maximum(H * H - K, 0))
        for _ in range(2):
            s = val.copy()
            cnt = np.ones(len(V))
            np.add.at(s, E[:, 0], val[E[:, 1]])
            np.add.at(s, E[:, 1], val[E[:, 0]])
            np.add.at(cnt, E[:, 0], 1)
            np.add.at(cnt, E[:, 1], 1)
            val = s / cnt
        score = val
        try:
            loops = dgmesh.topology(V, F).boundary_loops
            for lp in loops:
                score[np.asarray(lp)] = np.inf
        except dgmesh.MeshError:
            pass
    best = np.argsort(score, kind="stable")[:20]
    return int(best[seed % len(best)])


def laplacian_smooth(V, F, patch, iterations=500, factor=0.5):
    """Blender-like Smooth Vertices on the patch: `iterations` of moving each vertex by `factor`
    towards the mean of its neighbours (uniform umbrella), the rest fixed (numpy, no scipy)."""
    E = _edges(F)
    deg = np.bincount(E.ravel(), minlength=len(V)).astype(float)[:, None]
    W = V.copy()
    for _ in range(iterations):
        s = np.zeros_like(W)
        for c in range(3):
            s[:, c] = np.bincount(E[:, 0], weights=W[E[:, 1], c], minlength=len(V)) + \
                np.bincount(E[:, 1], weights=W[E[:, 0], c], minlength=len(V))
        W[patch] += factor * (s[patch] / deg[patch] - W[patch])
    return W


def cgal_fair(V, F, patch, build=True):
    """CGAL 5.5 Polygon_mesh_processing::fair (cotangent bi-Laplacian, continuity 1) of the patch's
    vertices on (V, F); (vertices, seconds) or None when the tool is missing or CGAL fails."""
    exe = cgal_tool(build)
    if exe is None:
        return None
    with tempfile.TemporaryDirectory() as d:
        d = pathlib.Path(d)
        _write_off(d / "in.off", V, F)
        np.savetxt(d / "mask.txt", np.flatnonzero(patch), fmt="%d")
        t0 = time.perf_counter()
        p = subprocess.run([str(exe), "fair", str(d / "in.off"), str(d / "mask.txt"), str(d / "out.off")],
                           capture_output=True, text=True)
        secs = time.perf_counter() - t0
        if p.returncode != 0:
            return None
        return _read_off(d / "out.off")[0], secs


def repair_case(V, F, patch, kind, seed=0, methods=("willmore", "bilaplacian"), cgal=True, smooth=True, **kw):
    """One damaged region restored by each method: {name: (mean distance / bbox diagonal, seconds, info)}
    with the distance of patch_distances (Metro-style mean over the region's faces, both ways) to the
    original region."""
    diag = bbox_diagonal(V)
    region, _rim = _region_of(F, patch)
    W = damage(V, F, patch, kind, seed)
    out = {"damaged": (patch_distances(V, F, region, W, F, region)[0] / diag, 0.0, {})}
    for m in methods:
        opts = dict(kw.get(m, {}))
        meth = opts.pop("method", m.split(":")[0])
        secs, r = _timed(lambda: dgmesh.fair(W, F, mask=patch, method=meth, **opts))
        reg = region[r.face_origin]
        moved = float(np.linalg.norm(r.vertices[:len(V)][patch] - W[patch], axis=1).max())
        out[m] = (patch_distances(V, F, region, r.vertices, r.faces, reg)[0] / diag, secs,
                  {"E0": float(r.energy[0]), "E": float(r.energy[-1]), "iterations": r.iterations,
                   "converged": bool(r.converged), "linear_start": bool(r.linear_start),
                   "max_move": moved / diag,
                   "status": r.stall.name, "restarted": bool(r.restarted)})
    if cgal:
        got = cgal_fair(W, F, patch)
        if got is not None:
            out["cgal_fair"] = (patch_distances(V, F, region, got[0], F, region)[0] / diag, got[1], {})
    if smooth:
        secs, Ws = _timed(lambda: laplacian_smooth(W, F, patch))
        out["smooth"] = (patch_distances(V, F, region, Ws, F, region)[0] / diag, secs, {})
    return out
