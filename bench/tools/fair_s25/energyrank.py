"""Whether the discrete Willmore energy (sum H^2 A over the region and its first fixed ring, what the
default flow lowers) ranks the original region above the flow's result (issue 30, session 25): per
fair_repair region (seed 0) at places W, energy[0] of dgmesh.fair with max_iterations=0 on the original,
on the bilaplacian result and on the default flow's result, beside the distances."""
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import B, damaged, dgmesh, distance  # noqa: E402

B._PER_FACE[0] = 1
wheres = os.environ.get("W", "flat").split(",")
n = above_flow = above_bil = 0
for name, V, F, where, frac, patch, region, kind, W, diag in damaged(wheres):
    try:
        r = dgmesh.fair(W, F, mask=patch)
        b = dgmesh.fair(W, F, mask=patch, method="bilaplacian")
        e = [dgmesh.fair(X, F, mask=patch, max_iterations=0).energy[0] for X in (V, b.vertices, r.vertices)]
    except dgmesh.MeshError:  # refused region, or a result with zero-area faces
        continue
    dw, db = distance(V, F, region, r, diag), distance(V, F, region, b, diag)
    n += 1
    above_flow += e[0] > e[2]
    above_bil += e[0] > e[1]
    print(f"{name}/{where}/{frac}/{kind}: E original {e[0]:.3f} bilaplacian {e[1]:.3f} flow {e[2]:.3f}; "
          f"distance flow {dw:.4f} bilaplacian {db:.4f}", flush=True)
print(f"{n} regions at {','.join(wheres)}: the original's energy above the flow result's on {above_flow}, "
      f"above the bilaplacian result's on {above_bil}")
