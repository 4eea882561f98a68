"""Session 29 (bench/notes/denoise.md): a fraction of a Taubin step where the step rule asks for less
than one (measured, not adopted). The rule's unrounded count k = auto_smoothing_steps before its
rounding (a numpy copy), and per row the normal error with the rounded count (the default), with one
step of lambda and mu scaled by sqrt(k) where k < 1 (that part of a step's low-pass term), and with
the fraction of every k (floor(k) steps and one of sqrt(k - floor(k))). Then the noise-free shapes the
rule must leave alone: their k (a fraction would move them).

    cd bench/tools/denoise_steps
    /usr/bin/python3 fraction.py bull,ChineseDragon-10kv,elephant,cow,camel,femur,triceratops,lion,dino,elk,mannequin-devil,hand 0,0.05,0.1,0.2 11
    /usr/bin/python3 fraction.py armadillo,man,bear,diplodocus,bunny00,fandisk,homer,lion-head,rotor_small,anchor_dense 0.05,0.1 31
    /usr/bin/python3 fraction.py clean
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(pathlib.Path(__file__).resolve().parent)]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import cgal_dir  # noqa: E402
from bench.workloads.denoise import normal_error  # noqa: E402
from rows import cube, sweep_inputs  # noqa: E402
from sweep_op import taubin as sweep_op_taubin  # noqa: E402


def rule_k(est):
    """auto_smoothing_steps (native/src/denoise.cpp) before its rounding."""
    sigma, detail = max(0.0, est.sigma), max(0.03, est.detail)
    excess = np.sqrt(max(0.0, sigma**2 - min(0.9 * detail, 0.1) ** 2))
    return min(9.5 * excess**1.8 / detail**1.5, 60)


def rows(models, levels, seed):
    for key, V, F, Vn, est in sweep_inputs(models, levels, seed):
        taubin = sweep_op_taubin(Vn, F)
        k = rule_k(est)
        whole = int(np.floor(k))
        P, steps = Vn.copy(), [Vn]
        for _ in range(max(whole, int(round(k)))):
            P = taubin(P)
            steps.append(P)
        rounded = normal_error(steps[int(round(k))], V, F)
        below_one = normal_error(taubin(Vn, np.sqrt(k)), V, F) if 0 < k < 1 else rounded
        every = normal_error(taubin(steps[whole], np.sqrt(k - whole)), V, F) if k > whole else normal_error(steps[whole], V, F)
        print(f"{key:36s} k {k:6.2f} noisy {normal_error(Vn, V, F):6.2f} | rounded {rounded:6.2f} | "
              f"fraction below one {below_one:6.2f} | every fraction {every:6.2f}", flush=True)


def clean():
    meshes = [(p.stem, *dgmesh.read_mesh(p)) for p in sorted(cgal_dir().glob("*.off"))]
    meshes += [(f"superellipsoid cube jitter {j} seed {s}", *cube(j, s)) for j, s in ((0.0, 3), (0.15, 3), (0.3, 3), (0.15, 4))]
    for name, V, F in meshes:
        V, F = np.asarray(V, float), np.asarray(F)
        if len(V) < 150 or len(F) == 0:
            continue
        est = dgmesh.estimate_noise(V, F)
        if rule_k(est) > 0:
            print(f"{name:40s} {len(V):7d} v  k {rule_k(est):.3f}  sigma {est.sigma:.4f}  detail {est.detail:.4f}", flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "clean":
        clean()
    else:
        rows(sys.argv[1].split(","), [float(x) for x in sys.argv[2].split(",")], int(sys.argv[3]))
