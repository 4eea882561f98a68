"""Issue 33, session 26: the fold guard (SkeletalDeformOptions::fold_guard, default 50) against
fold_guard=0 (the default before), with and without the untangling, and DQS with the same weights.
Self-intersecting triangle pairs over the whole mesh (native count), minimum ratio of the distance
to the bones (posed / rest), sum (f - f_rest)^2 of eq. 6.13 against the rig's posed skeleton.

    /usr/bin/python3 bench/tools/skeletal_fold_guard.py dense      # skeletal_speed's 178K capsule,
                                                                   # Gaussian and ramp weights, A/B ms
    /usr/bin/python3 bench/tools/skeletal_fold_guard.py capsule    # the untangle probe's capsule
    /usr/bin/python3 bench/tools/skeletal_fold_guard.py camel      # skeletal_limb's legs, Blender's
    /usr/bin/python3 bench/tools/skeletal_fold_guard.py armadillo  # automatic weights and DQS

With --contact (session 27) the variants are the default and the joint contact (contact_slide=3)
instead, e.g. `skeletal_fold_guard.py capsule --contact`; --contact=K for contact_slide=K.
"""
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import dgmesh  # noqa: E402
from dgmesh.skeletal import capsule, gaussian_bone_weights, self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402

VARIANTS = {"fold_guard=0": dict(fold_guard=0), "default": {},
            "untangle, fold_guard=0": dict(untangle_iterations=20, fold_guard=0),
            "untangle": dict(untangle_iterations=20)}


def row(label, X, F, ratio, thickness, ms=None):
    print("    %-24s pairs %6d  min ratio %.3f  sum (f-f_rest)^2 %.4g%s" % (
        label, len(self_intersecting_pairs(X, F)), ratio(X), thickness(X), "" if ms is None else "  %.1f ms" % ms),
        flush=True)


def dense():
    from bench.common import interleaved_medians
    from bench.workloads.skeletal import _bone_dist, _rot, dqs, ramp_weights, speed_capsule
    V, F, rest, heads, tails = speed_capsule()
    b0 = _bone_dist(V, rest, rest, heads, tails)
    ok = b0 > 1e-9
    axis = V.copy()
    axis[:, 1:] = 0
    for wname, W, Wq in (("Gaussian (the rig's, skeletal_speed)", None, gaussian_bone_weights(axis, heads, tails, 0.1)),
                         ("linear ramp over [-0.5, 0.5] (skeletal_live)", ramp_weights(V), ramp_weights(V))):
        rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
        f0 = dgmesh.union_of_balls_distance(V, rig.skeleton_vertices, rig.radii)
        out = np.empty((len(V), 3), np.float32)
        print(wname, len(V), "vertices", flush=True)
        for deg in (45, 60, 90, 135):
            pose = np.array([rest[0], _rot((0, 0, 1), np.radians(deg)) @ rest[1]])
            Sd = rig.skeleton_pose(pose)
            ratio = lambda X: (_bone_dist(X, rest, pose, heads, tails)[ok] / b0[ok]).min()  # noqa: E731
            thick = lambda X: ((dgmesh.union_of_balls_distance(X, Sd, rig.radii) - f0) ** 2).sum()  # noqa: E731
            print("  bend", deg, flush=True)
            row("DQS", dqs(V, Wq, rest, pose), F, ratio, thick)
            first = list(VARIANTS.items())[:2]
            ms = interleaved_medians([lambda o=o: rig.deform(pose, out=out, **o) for _, o in first])
            for (label, o), m in zip(first, ms):
                row(label, rig.deform(pose, **o), F, ratio, thick, 1e3 * m)


def capsule_probe():
    from skeletal_crease_probe import REST, bone_ratio_min, probe_poses, probe_rigs
    V, F = capsule(0.5, 6.0, 64, 10, 128)
    rigs = probe_rigs(V, F)
    f0 = dgmesh.union_of_balls_distance(V, rigs["whole"].skeleton_vertices, rigs["whole"].radii)
    for name, R in probe_poses().items():
        pose = np.array([REST[0], R @ REST[1]])
        Sd = rigs["whole"].skeleton_pose(pose)
        ratio = lambda X: bone_ratio_min(X, V, pose)  # noqa: E731
        thick = lambda X: ((dgmesh.union_of_balls_distance(X, Sd, rigs["whole"].radii) - f0) ** 2).sum()  # noqa: E731
        print(name, flush=True)
        row("DQS", skeletal_subspace_deform(V, rigs["whole"].weights, REST, pose, dual_quaternion=True), F, ratio, thick)
        for path, rig in rigs.items():
            for label, o in VARIANTS.items():
                row(f"{path} {label}", rig.deform(pose, **o), F, ratio, thick)


def legs(which):
    from bench.common import cgal_mesh
    from bench.workloads.skeletal_limb import ARMADILLO_BONES, CAMEL_BONES, armature_poses, bone_distance
    mesh, (heads, tails), bend_axis = {"camel": ("camel", CAMEL_BONES, (1, 0, 0)),
                                       "armadillo": ("armadillo", ARMADILLO_BONES, (-1, 0, 0))}[which]
    V, F = cgal_mesh(mesh)
    axis = tuple((tails[2] - heads[2]) / np.linalg.norm(tails[2] - heads[2]))
    poses = {"bend 45": (2, bend_axis, np.pi / 4), "bend 90": (2, bend_axis, np.pi / 2),
             "bend 135": (2, bend_axis, 3 * np.pi / 4), "twist 90": (2, axis, np.pi / 2), "twist 180": (2, axis, np.pi)}
    res = armature_poses(V, F, heads, tails, poses)[0]
    rest, W = res["rest"], res["W"]
    rigs = {"whole": dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=len(F) + 1),
            "multires": dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=5000)}
    b0 = bone_distance(V, rest, rest, heads, tails)
    aff = (W[:, 2] > 0.01) & (b0 > 1e-9)
    f0 = dgmesh.union_of_balls_distance(V, rigs["whole"].skeleton_vertices, rigs["whole"].radii)
    for p, name in enumerate(poses):
        pose = res[f"pose{p}"]
        Sd = rigs["whole"].skeleton_pose(pose)
        ratio = lambda X: (bone_distance(X, rest, pose, heads, tails) / np.maximum(b0, 1e-300))[aff].min()  # noqa: E731
        thick = lambda X: ((dgmesh.union_of_balls_distance(X, Sd, rigs["whole"].radii) - f0) ** 2).sum()  # noqa: E731
        print(which, name, flush=True)
        row("DQS (Blender)", res[f"dqs{p}"], F, ratio, thick)
        for path, rig in rigs.items():
            for label, o in VARIANTS.items():
                row(f"{path} {label}", rig.deform(pose, **o), F, ratio, thick)


if __name__ == "__main__":
    for arg in [a for a in sys.argv if a.split("=")[0] == "--contact"]:
        sys.argv.remove(arg)
        kappa = float(arg.split("=")[1]) if "=" in arg else 3.0
        VARIANTS = {"default": {}, f"contact_slide={kappa:g}": dict(contact_slide=kappa)}
    what = sys.argv[1] if len(sys.argv) > 1 else "capsule"
    {"dense": dense, "capsule": capsule_probe}.get(what, lambda: legs(what))()
