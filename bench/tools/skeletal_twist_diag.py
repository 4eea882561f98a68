"""Issue 33, session 25: two figures of bench/notes/skeletal.md's follow_twist section on the armadillo
waist twisted 180 degrees through a 5000-face control mesh (bench/tools/skeletal_twist_probe.py's
set-up; run that first, it caches Blender's matrices in $OUT): the control mesh's self-intersecting
pairs at rest and under DQS of its own weights, and how far the twist blended from a dense vertex's
base face corners (dual quaternions of the two bones, barycentric weights) is from the dense vertex's
own (its own ramp weight), over the waist (y in [-5, 25]).

    /usr/bin/python3 bench/tools/skeletal_twist_diag.py
"""
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT)]
import dgmesh  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402

V, F = cgal_mesh("armadillo")
t = np.clip(V[:, 1] / 20, 0, 1)
W = np.c_[1 - t, t]
res = dict(np.load(Path(os.environ.get("OUT", "/tmp")) / "skeletal_twist_probe_blender.npz"))
rest, pose = res["rest"], res["pose1"]
rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
Vc, Fc = rig.control_vertices, rig.control_faces
Xd = skeletal_subspace_deform(Vc, rig.weights, rest, pose, dual_quaternion=True)
print("control mesh pairs: rest %d, DQS %d" % (len(self_intersecting_pairs(Vc, Fc)), len(self_intersecting_pairs(Xd, Fc))))
a = rig.to_arrays()
st, face = a["mr_st"], a["mr_face"]
# A 180-degree twist of the second bone: the blend of (1, 0) and (0, axis) with weights (1 - w, w)
# is the quaternion (1 - w, w axis) / norm, a twist by 2 atan2(w, 1 - w).
q = np.c_[1 - rig.weights[:, 1], rig.weights[:, 1]]
q /= np.linalg.norm(q, axis=1)[:, None]
b = np.c_[1 - st.sum(1), st]
qb = (b[:, :, None] * q[Fc[face]]).sum(1)
qb /= np.linalg.norm(qb, axis=1)[:, None]
err = np.degrees(np.abs(2 * np.arctan2(qb[:, 1], qb[:, 0]) - 2 * np.arctan2(t, 1 - t)))
m = (V[:, 1] > -5) & (V[:, 1] < 25)
print("corners' blended twist against the vertex's own, waist: median %.2f, 90th percentile %.2f, max %.2f degrees"
      % (np.median(err[m]), np.percentile(err[m], 90), err[m].max()))
