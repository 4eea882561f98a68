"""Core workloads: curvature on a ~1M-triangle Loop-subdivided scan (target <= 0.5 s, 2 cores)."""

import numpy as np

import dgmesh
from bench.common import cgal_mesh, loop_subdivide, median_time, table


def curvature(quick):
    name = "bunny00"
    V0, F0 = cgal_mesh(name)
    levels = 1 if quick else 2
    V, F = loop_subdivide(V0, F0, levels)
    t_full, c = median_time(lambda: dgmesh.curvature(V, F), repeats=3 if quick else 7)
    t_valid, _ = median_time(lambda: dgmesh.validate(V, F), repeats=3 if quick else 7)
    assert np.isfinite(c["mean"]).all()
    rows = [
        ["curvature (validate + topology + H, K, normals)", len(V), len(F), t_full],
        ["of which validate + topology", len(V), len(F), t_valid],
    ]
    md = (f"Curvature of `{name}` from Debian's CGAL data, Loop-subdivided {levels}x (OpenSubdiv).\n"
          f"Target: at most 0.5 s for about 1M triangles on 2 cores.\n\n"
          + table(["step", "vertices", "faces", "median s"], rows))
    return {"markdown": md, "data": {"vertices": len(V), "faces": len(F), "seconds": t_full,
                                     "validate_seconds": t_valid}}


WORKLOADS = {"curvature": curvature}
