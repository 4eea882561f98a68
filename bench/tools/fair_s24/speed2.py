"""dgmesh.fair with its defaults on issue 30's case, twice: iterations, energy, seconds, distance."""
import os
import time

from _case import cpu, dgmesh, distance, issue_case

V, F, patch, W, region, diag = issue_case()
for rep in range(2):
    c0, t0 = cpu(), time.perf_counter()
    r = dgmesh.fair(W, F, mask=patch)
    t, c = time.perf_counter() - t0, cpu() - c0
    print(f"default it {r.iterations} conv {r.converged} E {r.energy[-1]:.5g} wall {t:.2f} cpu {c:.2f} "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
print(f"dist {distance(V, F, region, r, diag):.5f}", flush=True)
