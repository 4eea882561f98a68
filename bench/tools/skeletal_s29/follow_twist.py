"""follow_twist as a default? (issue 33, session 29). On bench skeletal_speed's 178K capsule with the
rig's Gaussian weights (no weights given): pairs and wall ms per pose with and without follow_twist
for bends and twists. (The skeletal_joints and armadillo-waist rows of the notes came from /tmp runs
of that bench's set-up and from bench/tools/skeletal_twist_probe.py.)

    /usr/bin/python3 bench/tools/skeletal_s29/follow_twist.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import interleaved_medians  # noqa: E402
from bench.workloads.skeletal import _rot, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F, rest, _, _ = speed_capsule(2)
rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
out = np.empty((rig.n_vertices, 3), dtype=np.float32)
for name, R in [("bend 60", _rot((0, 0, 1), np.pi / 3)), ("bend 90", _rot((0, 0, 1), np.pi / 2)),
                ("twist 90", _rot((1, 0, 0), np.pi / 2)), ("twist 180", _rot((1, 0, 0), np.pi * 0.999)),
                ("bend 60 + twist 45", _rot((0, 0, 1), np.pi / 3) @ _rot((1, 0, 0), np.pi / 4))]:
    pose = np.array([rest[0], R @ rest[1]])
    a, b = interleaved_medians([lambda: rig.deform(pose, out=out), lambda: rig.deform(pose, out=out, follow_twist=True)])
    pa = len(self_intersecting_pairs(rig.deform(pose), F))
    pb = len(self_intersecting_pairs(rig.deform(pose, follow_twist=True), F))
    print(f"{name:18s} default {1e3 * a:5.1f} ms, {pa:5d} pairs | follow_twist {1e3 * b:5.1f} ms, {pb:5d} pairs", flush=True)
