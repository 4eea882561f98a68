"""What Untangle Creases costs on bench skeletal_speed's 178K-vertex capsule (issue 33, session 28):
the default against untangle_iterations=20, through its 5000-face control mesh, with the rig's
Gaussian weights and the linear ramp over [-0.5, 0.5] (skeletal_live's), bends of 45 / 60 / 90 / 135
degrees. Per row: self-intersecting pairs over the whole mesh, minimum bone ratio, ms per pose
(float32 buffer, median of 3).

    /usr/bin/python3 bench/tools/skeletal_s28/untangle_cost.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import median_time  # noqa: E402
from bench.workloads.skeletal import _bone_dist, _rot, ramp_weights, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F, rest, heads, tails = speed_capsule()
b0 = _bone_dist(V, rest, rest, heads, tails)
ok = b0 > 1e-9
out = np.empty((len(V), 3), np.float32)
print(len(V), "vertices", flush=True)
for wname, W in (("Gaussian", None), ("ramp", ramp_weights(V))):
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
    for deg in (45, 60, 90, 135):
        pose = np.array([rest[0], _rot((0, 0, 1), np.radians(deg)) @ rest[1]])
        cells = []
        for label, kw in (("default", {}), ("untangle 20", dict(untangle_iterations=20))):
            X = rig.deform(pose, **kw)
            ms = 1e3 * median_time(lambda: rig.deform(pose, out=out, **kw), repeats=3)[0]
            ratio = (_bone_dist(X, rest, pose, heads, tails)[ok] / b0[ok]).min()
            cells.append("%s %d pairs (%.3f) %.0f ms" % (label, len(self_intersecting_pairs(X, F)), ratio, ms))
        print(wname, deg, " | ".join(cells), flush=True)
