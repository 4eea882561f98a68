"""Issue 33, session 34: what ring_twist costs at 178K vertices, on bench skeletal_speed's capsule
(Loop-subdivided twice, 5000-face control mesh, Gaussian weights), float32 buffer: its 60-degree bend
(no twist dominates: ring_twist does nothing) and a 180-degree twist of the second bone, with and
without ring_twist, interleaved; wall-clock medians of 9 per round, two rounds. The ring weights are
made at bind (one more sparse solve on the control mesh): bind time printed. Note the machine's load.

    /usr/bin/python3 bench/tools/skeletal_s34/ring_speed.py
"""
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT)]
import dgmesh  # noqa: E402
from bench.common import loop_subdivide, median_time  # noqa: E402
from bench.workloads.skeletal import _bone, _rot  # noqa: E402
from dgmesh.skeletal import capsule  # noqa: E402

V0, F0 = capsule(0.5, 6.0, 80, 10, 120)
V, F = loop_subdivide(V0, F0, 2)
rest = np.array([_bone((-3.5, 0, 0)), _bone((0, 0, 0))])
t0 = time.perf_counter()
rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
print("dense vertices", len(V), "bind %.2f s" % (time.perf_counter() - t0), "load", os.getloadavg())
out32 = np.empty((rig.n_vertices, 3), dtype=np.float32)
for rnd in range(2):
    for pname, pose in (("bend 60", np.array([rest[0], _rot((0, 0, 1), np.pi / 3) @ rest[1]])),
                        ("twist 180", np.array([rest[0], _rot((1, 0, 0), np.pi) @ rest[1]]))):
        for ring in (False, True):
            t, _ = median_time(lambda: rig.deform(pose, out=out32, ring_twist=ring), repeats=9)
            print("round %d %-9s ring_twist=%-5s wall %.1f ms" % (rnd, pname, ring, 1e3 * t), flush=True)
print("load", os.getloadavg())
