"""What the jet fit does on a G1 blend and what the noise test says on real meshes (issue #31).

    /usr/bin/python3 bench/tools/crest_blend_check.py

Rounded cube (shapes.rounded_cube(40, 0.25): blend radius 0.25, exact k_max = 4 across each rounded
edge): crest lines of the thesis fit (default) and of the jet fit, the share of crest points on the
middle of a blend, and k_max / |e_max| at vertices on the blends' middle lines. Then the noise
test's ratio and choice on CGAL's data meshes.
"""

import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "addon"))

import dgmesh  # noqa: E402
from dgmesh import shapes  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402


def main():
    V, F = shapes.rounded_cube(40, 0.25)
    mid = 0.75 + 0.25 / np.sqrt(2)  # |x| = |y| on the arc's middle
    Vs = np.sort(np.abs(V), axis=1)
    on_mid = (np.abs(Vs[:, 1] - mid) < 0.02) & (np.abs(Vs[:, 2] - mid) < 0.02) & (Vs[:, 0] < 0.7)
    for jet in (False, True):
        for k in (1, 2):
            cl = dgmesh.crest_lines(V, F, rings=k, jet=jet, threshold=0)
            P = np.sort(np.abs(cl.points), axis=1)
            share = ((np.abs(P[:, 1] - mid) < 0.05) & (np.abs(P[:, 2] - mid) < 0.05)).mean()
            d = dgmesh.curvature_derivatives(V, F, rings=k, jet=jet)
            print(f"rounded cube, jet={jet}, rings={k}: {len(cl.line_kind)} lines (T >= 0), {len(P)} points, "
                  f"{share:.0%} on a blend's middle; at blend-middle vertices k_max median "
                  f"{np.median(d.k_max[on_mid]):.3f} (exact 4), |e_max| median {np.median(np.abs(d.e_max[on_mid])):.2g}"
                  + (f"; noise ratio {d.noise_ratio:.2g}" if jet else ""))
    for name in ("fandisk", "bunny00", "armadillo"):
        V, F = cgal_mesh(name)
        d = dgmesh.curvature_derivatives(V, F, rings=1, jet=True)
        print(f"{name} ({len(F)} triangles): noise ratio {d.noise_ratio:.3f}, "
              + ("jet fit" if d.jet_used else "thesis fit"))


if __name__ == "__main__":
    main()
