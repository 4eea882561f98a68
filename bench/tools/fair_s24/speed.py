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
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF); return r.ru_utime + r.ru_stime
for sw in ["uniform", "cotangent", "uniform", "cotangent"]:
    c0, t0 = cpu(), time.perf_counter()
    r = dgmesh.fair(W, F, mask=patch, method="hinge", start_weights=sw, max_iterations=1)
    print(sw, len(V), int(patch.sum()), r.iterations, f"wall {time.perf_counter()-t0:.3f} cpu {cpu()-c0:.3f}", os.getloadavg()[0], flush=True)
