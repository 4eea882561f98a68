#!/usr/bin/env python3
"""Digest of dgmesh's outputs: one line per call of the public numpy API on small fixed inputs,
the call's name and the sha256 of its results (arrays by dtype, shape and bytes; scalars by repr).

For refactors that must not change any output: save the digest of the tree before, rebuild, and
diff. Every option is given explicitly, so changing a default does not change the digest. Wall
times (``seconds``, ``timings``) are left out. One CGAL scan (Debian's CGAL data, unpacked by
scripts/cgal_data.sh) is used when it is available and skipped otherwise. Results depend on the
thread count (BLAS reductions in fair's and unwrap's factorizations) but not on the run, so the
count is fixed (--threads, default 2). About 40 s on two cores.

    /usr/bin/python3 scripts/output_digest.py [--out FILE] [--only SUBSTRING]
"""

import argparse
import dataclasses
import hashlib
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "addon"))

import dgmesh  # noqa: E402
from dgmesh import shapes  # noqa: E402
from dgmesh.crest import crest_face_distance, feature_function, snap_to_vertices  # noqa: E402
from dgmesh.fairing import refine_region, subdivide_region  # noqa: E402
from dgmesh.skeletal import capsule, gaussian_bone_weights, skeletal_subspace_deform  # noqa: E402

SKIP_KEYS = ("seconds", "timings")


def feed(h, x):
    """Feeds x into the hash h, recursively and unambiguously."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        x = {f.name: getattr(x, f.name) for f in dataclasses.fields(x)}
    elif hasattr(type(x), "__fields__"):  # a bound options or result struct (bindings/common.h)
        x = {f: getattr(x, f) for f in type(x).__fields__}
    elif hasattr(type(x), "__members__"):  # a bound enum
        x = type(x).__name__ + "." + x.name
    elif type(x).__name__ == "CrestLines":  # the numpy API's thin class around the bound lines
        x = {"lines": x.lines, "derivatives": x.derivatives, "threshold": x.threshold}
    if isinstance(x, dict):
        h.update(b"{")
        for k in sorted(x, key=str):
            if any(s in str(k) for s in SKIP_KEYS):
                continue
            h.update(repr(k).encode() + b":")
            feed(h, x[k])
        h.update(b"}")
    elif isinstance(x, (list, tuple)):
        h.update(b"[%d" % len(x))
        for v in x:
            feed(h, v)
        h.update(b"]")
    elif isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        h.update(f"<{a.dtype.str}{a.shape}>".encode())
        h.update(a.tobytes())
    elif isinstance(x, np.generic):
        h.update(repr(x.item()).encode())
    elif x is None or isinstance(x, (bool, int, float, str)):
        h.update(repr(x).encode())
    else:
        raise TypeError(f"cannot digest {type(x).__name__}")


class Digest:
    def __init__(self, out, only):
        self.out, self.only, self.t0 = out, only, time.time()

    def __call__(self, name, fn, needed=False):
        """Runs fn() and prints name and the digest of its result (or the error it raised); returns
        the result. Calls left out by --only are not run, unless later calls need their result."""
        if self.only and self.only not in name:
            return fn() if needed else None
        t = time.time()
        try:
            r = fn()
            h = hashlib.sha256()
            feed(h, r)
            line = f"{name} {h.hexdigest()}"
        except dgmesh.Error as exc:
            r = None
            line = f"{name} raised {type(exc).__name__}: {exc}"
        self.out.write(line + "\n")
        self.out.flush()
        print(f"{time.time() - t:6.2f}s {name}", file=sys.stderr)
        return r


def noisy(V, F, sigma, seed):
    rng = np.random.default_rng(seed)
    e = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
    return V + rng.normal(0.0, sigma * e, V.shape)


def cgal_mesh(name):
    out = subprocess.run(["bash", str(ROOT / "scripts" / "cgal_data.sh")], capture_output=True, text=True)
    path = pathlib.Path(out.stdout.strip()) / name
    return dgmesh.read_mesh(path) if out.returncode == 0 and path.exists() else None


def bone(head):
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (0, -1, 0), (1, 0, 0), (0, 0, 1), head
    return m


def rot(axis, angle, pivot):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = R, np.asarray(pivot) - R @ np.asarray(pivot)
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="write the digest here (default: stdout)")
    ap.add_argument("--only", help="run only the calls whose name contains this")
    ap.add_argument("--threads", type=int, default=2,
                    help="OpenMP and BLAS threads (default 2): the supernodal factorizations' results depend "
                         "on the count (fair, unwrap), not on the run")
    args = ap.parse_args()
    dgmesh.set_num_threads(args.threads)
    out = open(args.out, "w") if args.out else sys.stdout
    d = Digest(out, args.only)

    # --- inputs ----------------------------------------------------------------------------------
    Vs, Fs = shapes.icosphere(3, 1.0)  # 642 vertices
    Vsn = noisy(Vs, Fs, 0.15, 1)
    Vt, Ft = shapes.torus(2.0, 0.7, 40, 20)
    Vtn = noisy(Vt, Ft, 0.1, 2)
    Vg, Fg = shapes.grid(24, 24)
    rng = np.random.default_rng(3)
    Vg = Vg.copy()
    Vg[:, 2] = 0.3 * np.sin(3 * Vg[:, 0]) * np.cos(2 * Vg[:, 1]) + rng.normal(0, 0.004, len(Vg))
    Vg[:, :2] += rng.normal(0, 0.004, (len(Vg), 2))
    Vc, Fc = shapes.rounded_cube(12, 0.3)
    Vc = np.asarray(Vc, dtype=np.float64)
    Fc = np.asarray(Fc, dtype=np.int32)
    # A spherical cap (disk) big enough for the multigrid solver (> 1000 vertices).
    Vh, Fh = shapes.icosphere(4, 1.0)
    keep = Vh[:, 2] > -0.3
    fk = keep[Fh].all(1)
    used = np.unique(Fh[fk])
    remap = np.full(len(Vh), -1, np.int32)
    remap[used] = np.arange(len(used), dtype=np.int32)
    Vcap, Fcap = Vh[used], remap[Fh[fk]]
    Vcap = noisy(Vcap, Fcap, 0.05, 4)
    # A hole region on the noisy sphere: vertices near the north pole move.
    hole = Vs[:, 2] > 0.75
    hole_faces = hole[Fs].any(1)
    # Point cloud: the noisy sphere's vertices with their exact normals.
    Ns = Vs / np.linalg.norm(Vs, axis=1, keepdims=True)

    # --- core, shapes, I/O -----------------------------------------------------------------------
    d("curvature", lambda: dgmesh.curvature(Vsn, Fs))
    d("topology", lambda: dgmesh.topology(Vg, Fg))
    d("validate", lambda: dgmesh.validate(Vsn, Fs, allow_loose_vertices=True))
    d("shapes.icosphere", lambda: shapes.icosphere(2, 1.5))
    d("shapes.torus", lambda: (Vt, Ft))
    d("shapes.grid", lambda: shapes.grid(5, 7))
    d("shapes.subdivide_linear", lambda: shapes.subdivide_linear(Vsn, Fs))
    d("shapes.loop_subdivide", lambda: shapes.loop_subdivide(Vsn, Fs, levels=1))
    d("shapes.rounded_cube", lambda: (Vc, Fc))
    d("shapes.capsule", lambda: capsule(radius=0.5, length=6.0, around=16, cap_rings=4, cylinder_rings=24))

    with tempfile.TemporaryDirectory() as tmp:
        for ext in ("obj", "off", "ply"):
            path = os.path.join(tmp, "mesh." + ext)

            def io_round_trip(path=path):
                dgmesh.write_mesh(path, Vsn, Fs, normals=None)
                raw = pathlib.Path(path).read_bytes()
                return np.frombuffer(raw, np.uint8), dgmesh.read_mesh(path)

            d(f"io.{ext}", io_round_trip)
            if ext != "off":

                def io_normals(path=path):
                    dgmesh.write_mesh(path, Vsn, Fs, normals=Ns)
                    raw = pathlib.Path(path).read_bytes()
                    return np.frombuffer(raw, np.uint8), dgmesh.read_mesh(path)

                d(f"io.{ext}.normals", io_normals)

    # --- denoise ---------------------------------------------------------------------------------
    for method in ("similarity", "bilateral"):
        d(f"denoise.mesh.{method}", lambda: dgmesh.denoise(
            Vsn, Fs, None, method=method, eta1=0.4, eta2=1.0, eta3=0.75, iterations=2, mask=None, progress=None))
        d(f"denoise.mesh.{method}.mask", lambda: dgmesh.denoise(
            Vtn, Ft, None, method=method, eta1=0.3, eta2=1.2, eta3=0.9, iterations=1, mask=Vt[:, 0] > 0,
            progress=None))
        d(f"denoise.points.{method}", lambda: dgmesh.denoise(
            Vsn, None, Ns, method=method, eta1=0.4, eta2=1.0, eta3=0.75, iterations=2, mask=None, progress=None))
    for mode in ("shape", "filter"):
        d(f"similarity.mesh.{mode}", lambda: dgmesh.similarity(
            Vsn, Fs, 7, None, eta1=0.4, eta3=0.75, mode=mode, progress=None))
        d(f"similarity.points.{mode}", lambda: dgmesh.similarity(
            Vsn, None, 7, Ns, eta1=0.4, eta3=0.75, mode=mode, progress=None))

    # --- fair ------------------------------------------------------------------------------------
    def fair(V, F, **kw):
        opts = dict(method="willmore", mask=None, faces=None, boundary="fixed", subdivisions=0, tolerance=1e-4,
                    max_iterations=40, tangential=True, scheme="semi_implicit", max_seconds=0.0, step_scale=1.0,
                    linear_start=True, refine=False, keep_size=True, progress=None)
        opts.update(kw)
        return dgmesh.fair(V, F, **opts)

    for method in ("willmore", "bilaplacian", "laplacian_of_h"):
        for scheme in ("explicit", "semi_implicit"):
            d(f"fair.region.{method}.{scheme}", lambda: fair(Vsn, Fs, method=method, scheme=scheme, mask=hole))
            d(f"fair.whole.{method}.{scheme}", lambda: fair(
                Vtn, Ft, method=method, scheme=scheme, max_iterations=15, keep_size=True))
    d("fair.region.no_linear_start", lambda: fair(Vsn, Fs, mask=hole, linear_start=False, tangential=False))
    d("fair.region.subdivisions", lambda: fair(Vsn, Fs, mask=hole, faces=hole_faces, subdivisions=1,
                                                max_iterations=20))
    d("fair.region.refine", lambda: fair(Vsn, Fs, mask=hole, refine=True, max_iterations=20))
    d("fair.whole.no_keep_size", lambda: fair(Vtn, Ft, keep_size=False, max_iterations=15))
    d("fair.grid.sliding", lambda: fair(Vg, Fg, boundary="sliding", max_iterations=20))
    d("fair.grid.sliding.explicit", lambda: fair(Vg, Fg, boundary="sliding", scheme="explicit",
                                                  max_iterations=60, step_scale=2.0))
    d("fair.two_regions", lambda: fair(Vsn, Fs, mask=hole | (Vs[:, 2] < -0.8), max_iterations=20))
    d("willmore_energy", lambda: dgmesh.willmore_energy(Vtn, Ft))
    d("subdivide_region", lambda: subdivide_region(Vsn, Fs, hole_faces))

    # A coarse fill: the cap above z = 0.6 removed and filled by a fan around a new centre vertex.
    def fan_fill():
        cut = Vs[:, 2] > 0.6
        fcut = cut[Fs].any(1)
        Fo = Fs[~fcut]
        used = np.unique(Fo)
        remap = np.full(len(Vs), -1, np.int32)
        remap[used] = np.arange(len(used), dtype=np.int32)
        V0, F0 = Vsn[used], remap[Fo]
        loop = dgmesh.topology(V0, F0).boundary_loops[0]
        c = len(V0)
        V1 = np.vstack([V0, V0[loop].mean(0)])
        directed = {(int(a), int(b)) for f in F0 for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
        if (int(loop[0]), int(loop[1])) in directed:
            loop = loop[::-1]  # the fill runs against the faces around the hole
        fan = np.array([[loop[i], loop[(i + 1) % len(loop)], c] for i in range(len(loop))], np.int32)
        F1 = np.vstack([F0, fan])
        return V1, F1, np.r_[np.zeros(len(F0), bool), np.ones(len(fan), bool)]

    Vf, Ff, ffill = fan_fill()
    d("refine_region", lambda: refine_region(Vf, Ff, ffill, density=2 ** 0.5))
    d("refine_region.dense", lambda: refine_region(Vf, Ff, ffill, density=2.0))
    d("fair.fill.refine", lambda: fair(Vf, Ff, faces=ffill, refine=True, max_iterations=20))
    d("fair.fill.subdivisions", lambda: fair(Vf, Ff, faces=ffill, subdivisions=2, max_iterations=10))
    for project in (True, False):
        d(f"regularize.whole.project={project}", lambda: dgmesh.regularize(
            Vtn, Ft, iterations=10, mask=None, boundary="fixed", step_scale=1.0, project=project, progress=None))
    d("regularize.region", lambda: dgmesh.regularize(
        Vsn, Fs, iterations=10, mask=hole, boundary="fixed", step_scale=0.5, project=True, progress=None))
    d("regularize.sliding", lambda: dgmesh.regularize(
        Vg, Fg, iterations=10, mask=None, boundary="sliding", step_scale=1.0, project=True, progress=None))

    # --- crest lines, decimate, segment ----------------------------------------------------------
    for rings in (1, 2):
        d(f"curvature_derivatives.rings={rings}", lambda: dgmesh.curvature_derivatives(
            Vc, Fc, rings=rings, smooth=True, use_normals=True, fit_tangent_plane=True, transport_to_vertex=True,
            progress=None))
    d("curvature_derivatives.thesis", lambda: dgmesh.curvature_derivatives(
        Vtn, Ft, rings=1, smooth=False, use_normals=False, fit_tangent_plane=False, transport_to_vertex=False,
        progress=None))
    crest_args = dict(rings=1, threshold=0.0, ridges=True, valleys=True, smooth=True, join_gaps=True,
                      skip_boundary=True, progress=None)
    lines = d("crest_lines", lambda: dgmesh.crest_lines(Vc, Fc, **crest_args), needed=True)
    d("crest_lines.torus", lambda: dgmesh.crest_lines(Vtn, Ft, **dict(crest_args, rings=2, join_gaps=False)))
    d("crest_lines.filter", lambda: lines.filter(threshold=0.5, ridges=True, valleys=False))
    dist = d("crest_face_distance", lambda: crest_face_distance(Vc, Fc, lines), needed=True)
    d("feature_function", lambda: feature_function(dist, 1.5, eps=0.1))
    d("snap_to_vertices", lambda: snap_to_vertices(lines, Vc, Fc))
    dec = dict(feature_weight=0.0, crest_lines=None, rings=1, threshold=0.0, preserve_boundary=True, min_quality=0.0,
               max_normal_angle=1.3, progress=None, return_map=True, return_face_map=True, locked=None, greedy=False,
               planes=None)
    for greedy in (False, True):
        d(f"decimate.greedy={greedy}", lambda: dgmesh.decimate(Vsn, Fs, target_faces=300, **dict(dec, greedy=greedy)))
    d("decimate.features", lambda: dgmesh.decimate(Vc, Fc, target_faces=400, **dict(
        dec, feature_weight=2.0, crest_lines=lines, min_quality=0.2)))
    d("decimate.detect", lambda: dgmesh.decimate(Vc, Fc, target_faces=400, **dict(dec, feature_weight=1.0, rings=2)))
    d("decimate.grid.locked", lambda: dgmesh.decimate(Vg, Fg, target_faces=200, **dict(
        dec, preserve_boundary=False, locked=Vg[:, 0] < 0.3, planes=(Vg[:, 1] < 1e-9).astype(np.int32))))
    seg = dict(feature_weight=0.0, crest_lines=None, rings=1, threshold=0.0, iterations=30, progress=None,
               return_info=True)
    d("segment", lambda: dgmesh.segment(Vc, Fc, segments=6, **seg))
    d("segment.features", lambda: dgmesh.segment(Vc, Fc, segments=8, **dict(seg, feature_weight=1.0,
                                                                             crest_lines=lines)))

    # --- unwrap ----------------------------------------------------------------------------------
    def unwrap(V, F, **kw):
        opts = dict(boundary="square", weights="floater", eta=1.0, iterations="optimal", slide_boundary=False,
                    max_iterations=20, min_improvement=1e-3, solver="umfpack", progress=None)
        opts.update(kw)
        return dgmesh.unwrap(V, F, **opts)

    for boundary in ("square", "circle", "free"):
        for weights in ("floater", "mean_value", "cotangent", "uniform", "auto"):
            d(f"unwrap.{boundary}.{weights}", lambda: unwrap(Vg, Fg, boundary=boundary, weights=weights))
    for solver in ("auto", "umfpack", "sparselu", "bicgstab", "multigrid"):
        d(f"unwrap.cap.{solver}", lambda: unwrap(Vcap, Fcap, solver=solver, max_iterations=6))
    d("unwrap.slide_boundary", lambda: unwrap(Vcap, Fcap, slide_boundary=True, eta=0.5, iterations=3))
    d("unwrap.iterations=0", lambda: unwrap(Vg, Fg, iterations=0, weights="cotangent"))
    UV = d("unwrap.grid.uv", lambda: unwrap(Vg, Fg, boundary="circle"), needed=True).uv
    d("uv_metrics", lambda: dgmesh.uv_metrics(Vg, Fg, UV, zero_area_eps=1e-10))
    d("uv_metrics.corners", lambda: dgmesh.uv_metrics(Vg, Fg, UV[Fg], zero_area_eps=1e-10))
    for per in ("vertex", "face"):
        d(f"uv_stretch.{per}", lambda: dgmesh.uv_stretch(Vg, Fg, UV, uv_faces=None, per=per, zero_area_eps=1e-10))
    d("uv_stretch.indexed", lambda: dgmesh.uv_stretch(Vg, Fg, UV[Fg].reshape(-1, 2),
                                                      uv_faces=np.arange(3 * len(Fg), dtype=np.int32).reshape(-1, 3),
                                                      per="face", zero_area_eps=1e-10))

    # --- remesh ----------------------------------------------------------------------------------
    def remesh(V, F, **kw):
        opts = dict(target_vertices=400, adaptivity=0.0, resolution=128, mode="double", boundary="keep",
                    domain="circle", boundary_clearance=0.5, flip_3d=True, eta=1.0, uopt_steps=-1,
                    lloyd_iterations=30, relax_metric="surface", min_separation=0.35, smooth_iterations=3,
                    progress=None)
        opts.update(kw)
        return dgmesh.remesh_full(V, F, **opts)

    for mode in ("double", "single_u0", "single_uopt"):
        d(f"remesh.{mode}", lambda: remesh(Vcap, Fcap, mode=mode))
    d("remesh.resample.square", lambda: remesh(Vcap, Fcap, boundary="resample", domain="square"))
    d("remesh.adaptive.map", lambda: remesh(Vcap, Fcap, adaptivity=1.0, relax_metric="map", min_separation=0.0))
    d("remesh.thesis", lambda: remesh(Vg, Fg, flip_3d=False, lloyd_iterations=0, smooth_iterations=0,
                                      uopt_steps=3, eta=0.5, boundary_clearance=1.0))
    d("remesh.grid", lambda: remesh(Vg, Fg, target_vertices=700, resolution=256))
    d("remesh.short", lambda: dgmesh.remesh(Vcap, Fcap, target_vertices=300, adaptivity=0.5, resolution=128,
                                            mode="double", boundary="keep", progress=None))
    d("point_mesh_distance", lambda: dgmesh.point_mesh_distance(Vtn[::3] * 1.05, Vt, Ft, candidates=16))
    d("point_mesh_distance.few", lambda: dgmesh.point_mesh_distance(Vsn, Vs, Fs, candidates=1))

    scan = cgal_mesh("lion-head.off")
    if scan is None:
        print("CGAL data not available: the scan's calls are skipped", file=sys.stderr)
    else:
        Vl, Fl = scan
        d("cgal.lion-head.remesh", lambda: remesh(Vl, Fl, target_vertices=2000, resolution=256))
        d("cgal.lion-head.unwrap", lambda: unwrap(Vl, Fl, weights="auto", solver="auto", max_iterations=8))
        d("cgal.lion-head.denoise", lambda: dgmesh.denoise(
            Vl, Fl, None, method="similarity", eta1=0.4, eta2=1.0, eta3=0.75, iterations=1, mask=None, progress=None))
        d("cgal.lion-head.regularize", lambda: dgmesh.regularize(
            Vl, Fl, iterations=5, mask=None, boundary="sliding", step_scale=1.0, project=True, progress=None))
        d("cgal.lion-head.unwrap.free", lambda: unwrap(Vl, Fl, boundary="free", weights="floater", solver="multigrid",
                                                       slide_boundary=False, max_iterations=4))
        d("cgal.lion-head.unwrap.slide", lambda: unwrap(Vl, Fl, boundary="square", weights="mean_value",
                                                        solver="bicgstab", slide_boundary=True, max_iterations=3))
        region = np.linalg.norm(Vl - Vl[100], axis=1) < 0.15 * np.ptp(Vl, axis=0).max()
        d("cgal.lion-head.fair.region", lambda: fair(Vl, Fl, mask=region, max_iterations=10))
        d("cgal.lion-head.fair.region.refine", lambda: fair(Vl, Fl, mask=region, refine=True, max_iterations=5))

    # --- large inputs: the parallel loops and the multigrid's larger levels ----------------------
    Vb, Fb = shapes.icosphere(7, 1.0)  # 163842 vertices
    Vbn = noisy(Vb, Fb, 0.1, 5)
    d("large.regularize", lambda: dgmesh.regularize(
        Vbn, Fb, iterations=2, mask=None, boundary="fixed", step_scale=1.0, project=True, progress=None))
    d("large.fair", lambda: fair(Vbn, Fb, max_iterations=2))
    d("large.curvature", lambda: dgmesh.curvature(Vbn, Fb))
    bk = Vb[:, 2] > -0.2
    bf = bk[Fb].all(1)
    bused = np.unique(Fb[bf])
    bremap = np.full(len(Vb), -1, np.int32)
    bremap[bused] = np.arange(len(bused), dtype=np.int32)
    Vbc, Fbc = Vbn[bused], bremap[Fb[bf]]
    d("large.unwrap.multigrid", lambda: unwrap(Vbc, Fbc, solver="multigrid", max_iterations=3))
    d("large.unwrap.auto.free", lambda: unwrap(Vbc, Fbc, boundary="free", weights="auto", solver="auto",
                                               max_iterations=2))
    d("large.remesh", lambda: remesh(Vbc, Fbc, target_vertices=20000, resolution=512))
    d("large.decimate", lambda: dgmesh.decimate(Vbn, Fb, target_faces=20000, **dec))

    # --- skeletal --------------------------------------------------------------------------------
    d("skeletal_mesh", lambda: dgmesh.skeletal_mesh(
        Vtn, Ft, presmooth_iterations=10, presmooth_step=0.2, postsmooth_iterations=20, postsmooth_step=0.2,
        spike_factor=2.5, max_pole_angle=1.2))
    Vk, Fk = capsule(radius=0.5, length=6.0, around=24, cap_rings=5, cylinder_rings=36)
    rest = np.array([bone((-3.5, 0, 0)), bone((0, 0, 0))])
    heads = np.array([[-3.5, 0, 0], [0, 0, 0.0]])
    tails = np.array([[0, 0, 0], [3.5, 0, 0.0]])
    bind = dict(bone_heads=heads, bone_tails=tails, control_faces=5000, multires_level=2, fit_iterations=1,
                gaussian_sigma=0.0, frame_regularization=0.05, presmooth_iterations=10, postsmooth_iterations=20,
                progress=None)
    rig = dgmesh.SkeletalRig.bind(Vk, Fk, rest, None, **bind)
    d("skeletal.bind", lambda: rig.to_arrays())
    pose = rest.copy()
    pose[1] = rot((0, 1, 0), 1.2, (0, 0, 0)) @ rest[1]
    twist = rest.copy()
    twist[1] = rot((1, 0, 0), 1.5, (0, 0, 0)) @ rest[1]
    dfm = dict(fairing_steps=2, method="variational", fairing_step=1.5, homotopy_steps=3, fold_iterations=10,
               projection=1.0, out=None, dual_quaternion=True, bone_clearance=0.95)
    d("skeletal.deform.variational", lambda: rig.deform(pose, **dfm))
    d("skeletal.deform.twist", lambda: rig.deform(twist, **dfm))
    d("skeletal.deform.basic", lambda: rig.deform(pose, **dict(dfm, method="basic")))
    d("skeletal.deform.linear_blend", lambda: rig.deform(twist, **dict(dfm, dual_quaternion=False, bone_clearance=0.0,
                                                                       projection=0.0)))
    d("skeletal.deform.float32", lambda: rig.deform(pose, **dict(dfm, out=np.zeros((len(Vk), 3), np.float32))))
    d("skeletal.deform_control", lambda: rig.deform_control(pose, **{k: v for k, v in dfm.items() if k != "out"}))
    d("skeletal.skeleton_pose", lambda: rig.skeleton_pose(twist))
    # Through the multiresolution layer: a denser capsule bound with a small control mesh.
    Vk2, Fk2 = capsule(radius=0.5, length=6.0, around=32, cap_rings=6, cylinder_rings=48)
    rig2 = dgmesh.SkeletalRig.bind(Vk2, Fk2, rest, None, **dict(bind, control_faces=600))
    d("skeletal.bind.multires", lambda: rig2.to_arrays())
    d("skeletal.deform.multires", lambda: rig2.deform(pose, **dfm))
    d("skeletal.deform.multires.twist", lambda: rig2.deform(twist, **dfm))
    W = gaussian_bone_weights(Vk, heads, tails, 0.8)
    d("gaussian_bone_weights", lambda: W)
    for dq in (False, True):
        d(f"skeletal_subspace_deform.dq={dq}", lambda: skeletal_subspace_deform(Vk, W, rest, twist, dual_quaternion=dq))
    centers = Vs[::7] * 0.5
    d("union_of_balls_distance", lambda: dgmesh.union_of_balls_distance(Vsn, centers,
                                                                        np.linspace(0.1, 0.4, len(centers))))
    d("delaunay_3d", lambda: dgmesh.delaunay_3d(Vsn[::3]))
    d("delaunay_2d", lambda: dgmesh.delaunay_2d(Vg[:, :2]))

    # --- multires --------------------------------------------------------------------------------
    Vm, Fm = shapes.loop_subdivide(Vtn, Ft, levels=1)
    mr = dgmesh.Multires.build(Vm, Fm, control_faces=800, level=2, min_quality=0.2, fit_iterations=1,
                               fit_regularization=1e-3, projection_iterations=12, progress=None)
    d("multires.build", lambda: mr.to_arrays())
    if True:
        X = mr.control_vertices * 1.1 + 0.05
        d("multires.reconstruct", lambda: mr.reconstruct(X))
        d("multires.reconstruct.float32", lambda: mr.reconstruct(X, out=np.zeros((mr.n_dense, 3), np.float32)))
        d("multires.limit_points", lambda: mr.limit_points(X))
        d("multires.limit_matrix", lambda: mr.limit_matrix())
        st = np.array([[0.2, 0.3], [0.0, 0.0], [1.0, 0.0], [0.1, 0.8]])
        d("multires.evaluate", lambda: mr.evaluate(np.array([0, 5, 9, 17]), st))
        d("multires.bind", lambda: dgmesh.Multires.bind(mr.control_vertices, mr.control_faces, Vtn, level=3,
                                                         projection_iterations=12, progress=None).to_arrays())
        d("multires.build.level1", lambda: dgmesh.Multires.build(
            Vtn, Ft, control_faces=400, level=1, min_quality=0.0, fit_iterations=0, fit_regularization=1e-3,
            projection_iterations=6, progress=None).to_arrays())

    print(f"{time.time() - d.t0:6.2f}s total", file=sys.stderr)


if __name__ == "__main__":
    main()
