"""Issue 33, session 35: what the joint fillet costs at 178K vertices, on bench skeletal_speed's capsule
(Loop-subdivided twice, 5000-face control mesh, Gaussian weights), float32 buffer: bends of 60 / 90
degrees of the second bone with the default (joint_fillet=2) and joint_fillet=0 (the integration),
interleaved; wall-clock medians of 9 per round, two rounds, and the crossing pairs of each. Note the
machine's load.

    /usr/bin/python3 bench/tools/skeletal_s35/fillet_speed.py
"""
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT)]
import dgmesh  # noqa: E402
from bench.common import median_time  # noqa: E402
from bench.workloads.skeletal import _rot, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F, rest, _, _ = speed_capsule()
rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
print("dense vertices", len(V), "load", os.getloadavg())
out32 = np.empty((rig.n_vertices, 3), dtype=np.float32)
poses = {a: np.array([rest[0], _rot((0, 0, 1), np.radians(a)) @ rest[1]]) for a in (60, 90)}
for a, pose in poses.items():
    for fillet in (2.0, 0.0):
        print("bend %d joint_fillet=%g: %d crossing pairs" % (
            a, fillet, len(self_intersecting_pairs(rig.deform(pose, joint_fillet=fillet), F))), flush=True)
for rnd in range(2):
    for a, pose in poses.items():
        for fillet in (2.0, 0.0):
            t, _ = median_time(lambda: rig.deform(pose, out=out32, joint_fillet=fillet), repeats=9)
            print("round %d bend %d joint_fillet=%g wall %.1f ms" % (rnd, a, fillet, 1e3 * t), flush=True)
print("load", os.getloadavg())
