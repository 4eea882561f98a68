"""Session 32 (issue 33): integrate_skeleton on skeletal_speed's 178K-vertex capsule (its Gaussian
weights and the linear ramp over x in [-0.5, 0.5]), bent 45 / 60 / 90 / 135 degrees: crossing triangle
pairs and ms per pose (median of 5, two interleaved rounds), defaults against integrate_skeleton=True.

    /usr/bin/python3 bench/tools/skeletal_s32/integrate_dense.py
"""
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import ramp_weights, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402


def main():
    V, F, rest, heads, tails = speed_capsule(2)
    for wname in ("Gaussian", "ramp"):
        rig = dgmesh.SkeletalRig.bind(V, F, rest, None if wname == "Gaussian" else ramp_weights(V),
                                      bone_heads=heads, bone_tails=tails)
        for a in (45, 60, 90, 135):
            c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
            P = np.eye(4)
            P[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
            pose = np.array([rest[0], P @ rest[1]])
            out = {}
            for integrate in (False, True, False, True):
                rig.deform(pose, integrate_skeleton=integrate)
                ts = []
                for _ in range(5):
                    t0 = time.perf_counter()
                    X = rig.deform(pose, integrate_skeleton=integrate)
                    ts.append(1e3 * (time.perf_counter() - t0))
                times = out.get(integrate, (0, []))[1]
                out[integrate] = (len(self_intersecting_pairs(X, F)), times + [float(np.median(ts))])
            print("%s %d degrees: default %d pairs, %s ms; integrated %d pairs, %s ms" % (
                wname, a, out[False][0], " / ".join("%.1f" % t for t in out[False][1]), out[True][0],
                " / ".join("%.1f" % t for t in out[True][1])), flush=True)


if __name__ == "__main__":
    main()
