"""Session 37 (issue 33): does the control mesh's fit make a thin limb's control mesh cross itself?
skeletal_speed's capsule at one subdivision level (44482 vertices) bound without weights on 1000 /
2000 / 3000 / 5000 control faces: the control mesh's self-intersecting pairs at rest, the mean / largest
displacement length, and the dense mesh's pairs with the second bone twisted 180 degrees.

    /usr/bin/python3 bench/tools/skeletal_s37/control_fit.py
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal import _rot, speed_capsule  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

V, F, rest, heads, tails = speed_capsule(1)
twist = np.array([rest[0], _rot((1, 0, 0), np.pi) @ rest[1]])
for faces in (1000, 2000, 3000, 5000):
    rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=faces)
    m = dgmesh.Multires.build(V, F, control_faces=faces)
    d = np.linalg.norm(np.asarray(m.displacement), axis=1)
    control, dense = rig.control_crossings(F)
    print(f"{faces} control faces: control pairs at rest {control} (mesh {dense}), displacement mean {d.mean():.4f} "
          f"max {d.max():.4f}, twisted 180 degrees {len(self_intersecting_pairs(rig.deform(twist), F))} pairs",
          flush=True)
