"""Wall and CPU seconds of the hinge's linear start, uniform against cotangent, on issue 30's case."""
import os
import time

from _case import cpu, dgmesh, issue_case

V, F, patch, W, _, _ = issue_case()
for sw in ["uniform", "cotangent", "uniform", "cotangent"]:
    c0, t0 = cpu(), time.perf_counter()
    r = dgmesh.fair(W, F, mask=patch, method="hinge", start_weights=sw, max_iterations=1)
    print(sw, len(V), int(patch.sum()), r.iterations, f"wall {time.perf_counter()-t0:.3f} cpu {cpu()-c0:.3f}",
          os.getloadavg()[0], flush=True)
