"""Session 25, a lead for what is left: does the triangulation say which roughness is shape? For every interior
edge (a, b) with opposite vertices c, d: the angle between its two faces' normals against the angle the flipped
edge (c, d) would make. A mesh whose edges follow its shape has few edges whose flip would be smoother; noise added
after the triangulation was made is blind to it. Prints the fraction of edges whose flip would be smoother, and the
median of (flipped - actual) angle over the median actual angle.
Usage: flips.py MODELS LEVELS SEED (MODELS as multiscale.py's)."""
import sys, pathlib
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(pathlib.Path(__file__).resolve().parent)]
import numpy as np
from multiscale import synthetic
from bench.workloads.denoise import add_noise, add_noise_isotropic


def interior_edges(F):
    """(a, b, c, d) for every edge shared by exactly two faces (a, b, c) and (b, a, d) of consistent orientation."""
    H = np.concatenate([F[:, [0, 1, 2]], F[:, [1, 2, 0]], F[:, [2, 0, 1]]])  # half-edge (a, b) with opposite c
    key = {}
    for a, b, c in H.tolist():
        key[(a, b)] = c
    out = []
    for (a, b), c in key.items():
        if a < b and (b, a) in key:
            out.append((a, b, c, key[(b, a)]))
    return np.array(out)


def angle(n1, n2):
    n1 = n1 / np.linalg.norm(n1, axis=1, keepdims=True); n2 = n2 / np.linalg.norm(n2, axis=1, keepdims=True)
    return np.arccos(np.clip(np.einsum("ij,ij->i", n1, n2), -1, 1))


def flip_stats(V, E):
    a, b, c, d = (V[E[:, i]] for i in range(4))
    actual = angle(np.cross(b - a, c - a), np.cross(a - b, d - b))
    flipped = angle(np.cross(d - c, a - c), np.cross(c - d, b - d))  # faces (c, d, a) and (d, c, b)
    ok = np.isfinite(actual) & np.isfinite(flipped)
    actual, flipped = actual[ok], flipped[ok]
    return float(np.mean(flipped < actual)), float(np.median(flipped - actual) / np.median(actual))


if __name__ == "__main__":
    models = sys.argv[1].split(","); levels = [float(x) for x in sys.argv[2].split(",")]; seed0 = int(sys.argv[3])
    for name in models:
        V, F = synthetic(name); V = np.asarray(V, float); F = np.asarray(F); E = interior_edges(F)
        row = []
        for kind in ("normal", "isotropic"):
            for lv in levels:
                if lv == 0 and kind == "isotropic":
                    continue
                Vn = V if lv == 0 else (add_noise if kind == "normal" else add_noise_isotropic)(V, F, lv, seed0 + int(lv * 1000))
                f, m = flip_stats(Vn, E)
                row.append(f"{kind[:3]} {lv}: {f:.3f} {m:+.2f}")
        print(f"{name:20s} " + " | ".join(row), flush=True)
