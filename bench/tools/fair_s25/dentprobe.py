"""The dent's scales on fair_repair's regions (issue 30, session 25): per region, the local feature size
`_dent` uses (median inner medial-ball radius over up to 200 patch vertices) and the patch's geodesic
radius (largest distance to the rim inside the patch), both over the bbox diagonal."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import B, regions  # noqa: E402

for name, V, F, where, frac, patch, _region in regions():
    diag = B.bbox_diagonal(V)
    rim = B._region_of(F, patch)[1]
    N = B._vertex_normals(V, F)
    g = B._distance_to(V, F, rim, patch | rim)[patch]
    idx = np.flatnonzero(patch)
    sub = np.random.default_rng(0).choice(idx, min(200, len(idx)), replace=False)
    lfs = float(np.median(B.inner_feature_size(V, N, sub)))
    print(f"{name}/{where}/{frac}: lfs {lfs / diag:.4f}, geodesic radius {g[np.isfinite(g)].max() / diag:.4f}", flush=True)
