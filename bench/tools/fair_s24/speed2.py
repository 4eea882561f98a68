import sys, os, time, resource
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
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF); return r.ru_utime + r.ru_stime
for rep in range(2):
    c0, t0 = cpu(), time.perf_counter()
    r = dgmesh.fair(W, F, mask=patch)
    t, c = time.perf_counter() - t0, cpu() - c0
    print(f"default it {r.iterations} conv {r.converged} E {r.energy[-1]:.5g} wall {t:.2f} cpu {c:.2f} load {os.getloadavg()[0]:.1f}", flush=True)
d = B.patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0] / diag
print(f"dist {d:.5f}", flush=True)
