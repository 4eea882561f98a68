import sys, time
from pathlib import Path as _Path
REPO = str(_Path(__file__).resolve().parents[3])  # the checkout this script lies in
OUT = __import__("os").environ.get("OUT", "/tmp/dgmesh-fair-s24")  # where its data goes
sys.path.insert(0, REPO); sys.path.insert(0, REPO + '/addon')
import dgmesh
from bench.workloads import fair as B
V, F = B.cgal_mesh("armadillo")
V, F = dgmesh.shapes.subdivide_linear(V, F)
patch = B.vertex_ball(V, F, B.region_centre(V, F, "saddle"), int(0.06 * len(V)))
W = B.damage(V, F, patch, "flat")
diag = B.bbox_diagonal(V)
region, _ = B._region_of(F, patch)
its = [int(a) for a in sys.argv[1:]] or [3, 5, 8, 12, 20, 56]
for k in its:
    t0 = time.perf_counter()
    r = dgmesh.fair(W, F, mask=patch, max_iterations=k)
    t = time.perf_counter() - t0
    d = B.patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0] / diag
    print(k, r.iterations, f"E {r.energy[-1]:.5g} dist {d:.5f} wall {t:.2f} conv {r.converged}", flush=True)
