"""Cost of the jet fit's noise test (DerivativeOptions::noise_adaptive): median wall time of
curvature_derivatives(jet=True, rings=1) with and without it on a 327K-triangle ellipsoid (exact, so the
jet fit is used either way), 5 runs each.

    /usr/bin/python3 bench/tools/crest_noise_cost.py
"""

import os
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "addon"))

import dgmesh  # noqa: E402
from dgmesh import shapes  # noqa: E402


def main():
    V, F = shapes.icosphere(7)
    V = V * np.array([1.0, 0.8, 0.6])
    print(f"{len(F)} triangles, load average {os.getloadavg()[0]:.1f} at the start")
    for adaptive in (False, True):
        ts = []
        for _ in range(5):
            t = time.perf_counter()
            d = dgmesh.curvature_derivatives(V, F, rings=1, jet=True, noise_adaptive=adaptive)
            ts.append(time.perf_counter() - t)
        print(f"noise_adaptive={adaptive}: median {np.median(ts):.3f} s (ratio {d.noise_ratio:.3f}, jet used: {d.jet_used})")


if __name__ == "__main__":
    main()
