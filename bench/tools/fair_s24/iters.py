"""The Willmore flow on issue 30's case capped at k iterations (arguments; default 3 5 8 12 20 56):
energy, distance, seconds."""
import sys
import time

from _case import dgmesh, distance, issue_case

V, F, patch, W, region, diag = issue_case()
for k in [int(a) for a in sys.argv[1:]] or [3, 5, 8, 12, 20, 56]:
    t0 = time.perf_counter()
    r = dgmesh.fair(W, F, mask=patch, max_iterations=k)
    t = time.perf_counter() - t0
    print(k, r.iterations, f"E {r.energy[-1]:.5g} dist {distance(V, F, region, r, diag):.5f} wall {t:.2f} "
          f"conv {r.converged}", flush=True)
