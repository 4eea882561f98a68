"""Issue 33, session 25: per-pose deform time at 178K vertices with and without follow_twist, on bench
skeletal_speed's capsule (Loop-subdivided twice, 5000-face control mesh, Gaussian weights), float32
buffer: its 60-degree bend (no twist: follow_twist does nothing) and a 180-degree twist of the second
bone. Wall-clock medians of 9 and CPU time per call (all threads); note the machine's load (printed).

    /usr/bin/python3 bench/tools/skeletal_twist_speed.py
"""
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT)]
import dgmesh  # noqa: E402
from bench.common import loop_subdivide, median_time  # noqa: E402
from bench.workloads.skeletal import _bone, _rot  # noqa: E402
from dgmesh.skeletal import capsule  # noqa: E402

V0, F0 = capsule(0.5, 6.0, 80, 10, 120)
V, F = loop_subdivide(V0, F0, 2)
rest = np.array([_bone((-3.5, 0, 0)), _bone((0, 0, 0))])
rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
out32 = np.empty((rig.n_vertices, 3), dtype=np.float32)
print("dense vertices", len(V), "load", os.getloadavg())
for pname, pose in (("bend 60", np.array([rest[0], _rot((0, 0, 1), np.pi / 3) @ rest[1]])),
                    ("twist 180", np.array([rest[0], _rot((1, 0, 0), np.pi) @ rest[1]]))):
    for ft in (False, True):
        fn = lambda: rig.deform(pose, out=out32, follow_twist=ft)  # noqa: E731
        t, _ = median_time(fn, repeats=9)
        c0 = time.process_time()
        for _ in range(9):
            fn()
        cpu = (time.process_time() - c0) / 9
        print("%-9s follow_twist=%-5s  wall %.1f ms  CPU %.1f ms" % (pname, ft, 1e3 * t, 1e3 * cpu), flush=True)
print("load", os.getloadavg())
