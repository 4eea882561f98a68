"""Core workloads: curvature on ~1M-triangle Loop-subdivided scans (target <= 0.5 s, 2 cores)."""

import numpy as np

import dgmesh
from bench.common import cgal_mesh, loop_subdivide, median_time, table


def curvature(quick):
    rows, data = [], {}
    for name in ("armadillo", "bunny00"):
        V0, F0 = cgal_mesh(name)
        levels = 1 if quick else 2
        V, F = loop_subdivide(V0, F0, levels)
        t_full, c = median_time(lambda: dgmesh.curvature(V, F), repeats=3 if quick else 7)
        t_valid, _ = median_time(lambda: dgmesh.validate(V, F), repeats=3 if quick else 7)
        assert np.isfinite(c.mean).all()
        rows.append([f"{name}, Loop {levels}x", len(V), len(F), t_full, t_valid, t_full / len(F) * 1e6])
        data[name] = {"vertices": len(V), "faces": len(F), "seconds": t_full, "validate_seconds": t_valid}
    md = ("Curvature (`dgmesh.curvature`: validation + topology + H, K, normals, areas) of scans from "
          "Debian's CGAL data, Loop-subdivided with OpenSubdiv. Target: at most 0.5 s for about 1M "
          "triangles on 2 cores.\n\n"
          + table(["mesh", "vertices", "faces", "median s", "of which validate + topology s",
                   "s per 1M faces"], rows))
    return {"markdown": md, "data": data}


WORKLOADS = {"curvature": curvature}
