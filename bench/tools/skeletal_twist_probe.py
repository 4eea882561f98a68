"""Issue 33, session 25: the armadillo-waist rows of bench skeletal_blender (bend 90, twist 180) only,
with and without SkeletalDeformOptions::follow_twist, whole mesh and through the multiresolution layer
(5000-face control mesh, the operator's path above 5000 faces), default and untangled
(untangle_iterations=10 and 20). Same set-up as bench/workloads/skeletal.py's _blender_case: CGAL armadillo,
bones (0,-54,0)-(0,10,0)-(0,97,0), weights a linear ramp over y in [0, 20], Blender's Armature
modifier (Preserve Volume = DQS) and pose matrices, cached in $OUT (default /tmp) after the first
run. Metrics as the bench: self-intersecting pairs (native count), sum (f - f_rest)^2 against the
whole-mesh rig's posed skeletal mesh, min ratio of the distance to the bone segments, volume ratio.

    /usr/bin/python3 bench/tools/skeletal_twist_probe.py [--poses "twist 180,bend 90"] [--paths whole,multires]
"""
import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT)]
import dgmesh  # noqa: E402
from bench.common import cgal_mesh, run_blender  # noqa: E402
from bench.workloads.skeletal import BLENDER_SCRIPT, _bone_dist, _volume  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

HEADS = np.array([[0, -54, 0], [0, 10, 0.0]])
TAILS = np.array([[0, 10, 0], [0, 97, 0.0]])
POSES = {"bend 90": (0.0, 0.0, np.pi / 2), "twist 180": (0.0, np.pi, 0.0)}


def blender_poses(V, F, W):
    cache = Path(os.environ.get("OUT", "/tmp")) / "skeletal_twist_probe_blender.npz"
    if not cache.exists():
        with tempfile.TemporaryDirectory() as tmp:
            inp = Path(tmp) / "in.npz"
            np.savez(inp, V=V, F=F, W=W, heads=HEADS, tails=TAILS, poses=np.array(list(POSES.values())))
            run_blender(BLENDER_SCRIPT, [inp, cache])
    return dict(np.load(cache))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--poses", default=",".join(POSES))
    ap.add_argument("--paths", default="whole,multires")
    ap.add_argument("--untangle", type=int, default=1, help="also the untangled rows (1) or not (0)")
    args = ap.parse_args()
    V, F = cgal_mesh("armadillo")
    t = np.clip(V[:, 1] / 20.0, 0, 1)
    W = np.c_[1 - t, t]
    res = blender_poses(V, F, W)
    rest = res["rest"]
    rigs = {"whole": dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=len(F) + 1)}
    if "multires" in args.paths:
        rigs["multires"] = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
    rig = rigs["whole"]
    f_rest = dgmesh.union_of_balls_distance(V, rig.skeleton_vertices, rig.radii)
    b0 = _bone_dist(V, rest, rest, HEADS, TAILS)
    ok = b0 > 1e-9
    vol0 = _volume(V, F)
    names = list(POSES)
    for pname in args.poses.split(","):
        p = names.index(pname)
        pose = res[f"pose{p}"]
        _, Sd = rig.deform_control(pose)

        def row(label, X, secs=None):
            f = dgmesh.union_of_balls_distance(X, Sd, rig.radii)
            r = _bone_dist(X, rest, pose, HEADS, TAILS)[ok] / b0[ok]
            print("%-10s %-40s pairs %6d  sum(f-f_rest)^2 %10.4g  min ratio %.3f  volume %.4f%s" % (
                pname, label, len(self_intersecting_pairs(X, F)), ((f - f_rest) ** 2).sum(), r.min(),
                _volume(X, F) / vol0, "" if secs is None else "  (%.2f s)" % secs), flush=True)

        row("DQS (Blender Preserve Volume)", res[f"dqs{p}"])
        for path in args.paths.split(","):
            for twist in (False, True):
                for unt in ((0, 10, 20) if args.untangle else (0,)):
                    t0 = time.perf_counter()
                    X = rigs[path].deform(pose, follow_twist=twist, untangle_iterations=unt)
                    row("%s%s%s" % (path, " follow_twist" if twist else "", (" untangle %d" % unt) if unt else ""), X,
                        time.perf_counter() - t0)


if __name__ == "__main__":
    main()
