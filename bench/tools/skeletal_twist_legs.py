"""Issue 33, session 25: SkeletalDeformOptions::follow_twist on the bench skeletal_limb legs (camel,
armadillo): Blender's automatic weights and Armature modifier (DQS = Preserve Volume) through
bench/workloads/_skeletal_limb.py (cached in $OUT, default /tmp), ours on the whole mesh and through the
multiresolution layer (5000-face control mesh), default and untangled (untangle_iterations=20), each
without / with follow_twist. Per row: self-intersecting pairs over the whole mesh (native count),
sum (f - f_rest)^2 against the whole-mesh rig's posed skeletal mesh (as bench skeletal_limb), min
ratio of the distance to the bones over the vertices with weight on the moving bone (bench
skeletal_limb's bone_distance), volume ratio.

    /usr/bin/python3 bench/tools/skeletal_twist_legs.py camel|armadillo [--poses "twist 180,bend 90"] [--untangle 0|1]
        [--paths whole,multires] [--extra "projection=0"]  (extra: deform keyword arguments, floats)
"""
import argparse
import os
import pathlib
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import dgmesh  # noqa: E402
from bench.common import cgal_mesh, run_blender  # noqa: E402
from bench.workloads.skeletal import _volume  # noqa: E402
from bench.workloads.skeletal_limb import ARMADILLO_BONES, CAMEL_BONES, LIMB_SCRIPT, bone_distance  # noqa: E402
from dgmesh.skeletal import self_intersecting_pairs  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("which", choices=["camel", "armadillo"])
ap.add_argument("--poses", default="bend 45,bend 90,bend 135,twist 90,twist 180")
ap.add_argument("--untangle", type=int, default=1)
ap.add_argument("--paths", default="whole,multires")
ap.add_argument("--extra", default="")
args = ap.parse_args()
extra = {k: float(v) for k, v in (kv.split("=") for kv in args.extra.split(",") if kv)}
mesh, (heads, tails), bend_axis = {"camel": ("camel", CAMEL_BONES, (1, 0, 0)),
                                   "armadillo": ("armadillo", ARMADILLO_BONES, (-1, 0, 0))}[args.which]
V, F = cgal_mesh(mesh)
axis = tails[2] - heads[2]
poses = {"bend 45": (2, bend_axis, np.pi / 4), "bend 90": (2, bend_axis, np.pi / 2),
         "bend 135": (2, bend_axis, 3 * np.pi / 4), "twist 180": (2, tuple(axis / np.linalg.norm(axis)), np.pi),
         "twist 90": (2, tuple(axis / np.linalg.norm(axis)), np.pi / 2)}
cache = pathlib.Path(os.environ.get("OUT", "/tmp")) / f"skeletal_twist_legs_{args.which}.npz"
if not cache.exists() or f"pose{len(poses) - 1}" not in np.load(cache):  # (a cache from before twist 90)
    with tempfile.TemporaryDirectory() as tmp:
        inp = pathlib.Path(tmp) / "in.npz"
        np.savez(inp, V=V, F=F, heads=heads, tails=tails,
                 poses=np.array([[b, *ax, ang] for b, ax, ang in poses.values()], dtype=float))
        run_blender(LIMB_SCRIPT, [inp, cache])
res = dict(np.load(cache))
rest, W = res["rest"], res["W"]
rig = dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=len(F) + 1)
rig_mr = dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=5000)
f_rest = dgmesh.union_of_balls_distance(V, rig.skeleton_vertices, rig.radii)
b0 = bone_distance(V, rest, rest, heads, tails)
aff = (W[:, 2] > 0.01) & (b0 > 1e-9)
vol0 = _volume(V, F)
names = list(poses)
for pname in args.poses.split(","):
    p = names.index(pname)
    pose = res[f"pose{p}"]
    _, Sd = rig.deform_control(pose)
    out = {"DQS (Blender)": lambda: res[f"dqs{p}"]}
    for path, r in (p for p in (("whole", rig), ("multires", rig_mr)) if p[0] in args.paths.split(",")):
        for ft in (False, True):
            for unt in ((0, 20) if args.untangle else (0,)):
                out["%s%s%s" % (path, " follow_twist" if ft else "", " untangle" if unt else "")] = (
                    lambda r=r, ft=ft, unt=unt: r.deform(pose, follow_twist=ft, untangle_iterations=unt, **extra))
    for k, fn in out.items():
        X = fn()
        f = dgmesh.union_of_balls_distance(X, Sd, rig.radii)
        ratio = (bone_distance(X, rest, pose, heads, tails) / np.maximum(b0, 1e-300))[aff]
        print("%s %-9s %-32s pairs %5d  sum(f-f_rest)^2 %9.4g  min ratio %.3f  volume %.4f" % (
            args.which, pname, k, len(self_intersecting_pairs(X, F)), ((f - f_rest) ** 2).sum(), ratio.min(),
            _volume(X, F) / vol0), flush=True)
