"""Session 23 (bench/notes/denoise.md): the default on every noise-free CGAL mesh of at least 1000 vertices
(estimate, what ran, normal error against the input). Usage: clean_scans.py [NAMES|""] OUT.json."""
import sys, pathlib, json
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from bench.common import cgal_dir
from bench.workloads.denoise import normal_error
out = {}
names = sys.argv[1].split(",") if len(sys.argv) > 1 and sys.argv[1] else sorted(p.stem for p in cgal_dir().glob("*.off"))
for name in names:
    try:
        V, F = dgmesh.read_mesh(cgal_dir() / f"{name}.off"); V = np.asarray(V, float); F = np.asarray(F)
    except Exception as ex:
        print(f"{name:24s} unreadable: {ex}"); continue
    if len(V) < 1000 or len(F) == 0: continue
    try:
        r = dgmesh.denoise(V, F)
    except Exception as ex:
        print(f"{name:24s} {len(V):7d} v error: {ex}", flush=True); continue
    n = r.noise; st = r.options.smoothing_steps
    ch = ("nothing" if r.options.iterations == 0 else "filter") if st == 0 else f"Taubin {st}"
    err = normal_error(r.vertices, V, F)
    out[name] = dict(v=len(V), sigma=n.sigma, detail=n.detail, curv=n.curvature, outl=n.outliers, choice=ch, err=err)
    print(f"{name:24s} {len(V):7d} v sigma {n.sigma:.3f} detail {n.detail:.3f} curv {n.curvature:.2f} outl {n.outliers:.3f} -> {ch}: {err:.2f} deg", flush=True)
json.dump(out, open(sys.argv[2] if len(sys.argv) > 2 else "clean_all.json", "w"), indent=1)
