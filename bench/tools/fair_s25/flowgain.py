"""Where the default Willmore flow moves a region away from its linear start (issue 30, session 25):
on fair_repair's regions (seed $SEED), the distance / diagonal of the linear start alone
(max_iterations=1: U0^2 P = 0, the bilaplacian flow's steady state) and of the default flow, with the
energies at the input, after the linear start and at the end, and whether it restarted.
Writes $OUT/flowgain_seed$SEED.json."""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import OUT, SEED, B, dgmesh, distance, regions  # noqa: E402

out = {}
B._PER_FACE[0] = 1
for name, V, F, where, frac, patch, region in regions():
    diag = B.bbox_diagonal(V)
    for kind in ["flat", "dent", "noise"]:
        W = B.damage(V, F, patch, kind)
        try:
            r1 = dgmesh.fair(W, F, mask=patch, max_iterations=1)
            r = dgmesh.fair(W, F, mask=patch)
            bl = dgmesh.fair(W, F, mask=patch, method="bilaplacian")
        except dgmesh.MeshError:
            continue
        key = f"{name}/{where}/{frac}/{kind}"
        e = np.asarray(r.energy)
        out[key] = dict(lin=distance(V, F, region, r1, diag), flow=distance(V, F, region, r, diag),
                        bilaplacian=distance(V, F, region, bl, diag), lin_taken=bool(r1.linear_start),
                        restarted=bool(r.restarted), iterations=int(r.iterations), e_in=float(e[0]),
                        e_lin=float(np.asarray(r1.energy)[-1]), e_end=float(e[-1]))
        print(key, {k: (round(v, 5) if isinstance(v, float) else v) for k, v in out[key].items()}, flush=True)
json.dump(out, open(f"{OUT}/flowgain_seed{SEED}.json", "w"))
