"""Diagnosis (issue 30, session 25): does the Willmore flow lose to the bilaplacian flow on flat-ish
areas because of the scan's noise? The same regions as fair_repair (places W, default flat) on each
scan after 20 Taubin steps (lambda 0.5, mu -0.53, uniform umbrella, whole mesh) taken as the
original; damaged, faired, mean distance / diagonal; won/tied/lost (5%) of the default against the
bilaplacian flow, and the same on the raw scans."""
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import B, dgmesh, distance  # noqa: E402

B._PER_FACE[0] = 1
wheres = os.environ.get("W", "flat").split(",")


def taubin(V, F, steps=20, lam=0.5, mu=-0.53):
    E = B._edges(F)
    deg = np.bincount(E.ravel(), minlength=len(V)).astype(float)[:, None]
    W = V.copy()
    for _ in range(steps):
        for f in (lam, mu):
            s = np.zeros_like(W)
            for c in range(3):
                s[:, c] = np.bincount(E[:, 0], weights=W[E[:, 1], c], minlength=len(V)) + \
                    np.bincount(E[:, 1], weights=W[E[:, 0], c], minlength=len(V))
            W += f * (s / deg - W)
    return W


for smooth in (False, True):
    tally, mw, mb = {"won": 0, "tied": 0, "lost": 0}, [], []
    for name in B._REPAIR_MESHES:
        V0, F = B.cgal_mesh(name)
        V = taubin(V0, F) if smooth else V0
        diag = B.bbox_diagonal(V)
        for where in wheres:
            centre = B.region_centre(V0, F, where)
            for frac in (0.02, 0.06, 0.12):
                patch = B.vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
                region = B._region_of(F, patch)[0]
                for kind in ("flat", "dent", "noise"):
                    W = B.damage(V, F, patch, kind)
                    try:
                        w = distance(V, F, region, dgmesh.fair(W, F, mask=patch), diag)
                        b = distance(V, F, region, dgmesh.fair(W, F, mask=patch, method="bilaplacian"), diag)
                    except dgmesh.MeshError:
                        continue
                    tally[B._verdict(w, b)] += 1
                    mw.append(w)
                    mb.append(b)
    print(f"{'Taubin-smoothed' if smooth else 'raw'} scans, {','.join(wheres)}: Willmore {np.mean(mw):.5f}, "
          f"bilaplacian {np.mean(mb):.5f}, Willmore vs bilaplacian {tally['won']}/{tally['tied']}/{tally['lost']}", flush=True)
