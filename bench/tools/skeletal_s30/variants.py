"""Session 30 (issue 33): the joint bar and the crease over an animation for one set of deform options.
skeletal_joints' meshes and Blender's automatic weights (cached per mesh in $CACHE, default
/tmp/dgmesh_s30; one Blender run each), the moving bone bent 30 -> 135 degrees one degree per frame and
twisted 0 -> 180 two degrees per frame, through the 5000-face control mesh (PATHS=layer, the default) or
on the whole mesh (PATHS=whole). Per sweep: the frames where some vertex's second difference over three
frames exceeds one edge length (as bench skeletal_coherence) and the largest; at the joint poses
(bends 45 / 90 / 135, twists 90 / 180) ours / DQS crossing pairs, the minimum bone ratio (as
skeletal_joints; * = misses issue 33's bar), t = ours / DQS sum (f - f_rest)^2 against the rig's posed
skeleton (as skeletal_limb), and the largest / smallest f - f_rest in edge lengths, DQS's in brackets
(positive: farther from the union of balls than at rest, a bulge). VERBOSE=1 lists the jump frames
(angle: largest / vertices over one edge length).

    /usr/bin/python3 bench/tools/skeletal_s30/variants.py TAG [option=value ...]
    e.g. variants.py pr0 projection=0;  MODELS=armadillo VERBOSE=1 variants.py fg0 fold_guard=0
"""
import json
import os
import pathlib
import pickle
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.workloads.skeletal_limb import (_joint_cases, armature_poses, bone_distance, joint_bar,  # noqa: E402
                                           min_bone_ratio, moving_vertices, path_jumps)
from dgmesh.skeletal import self_intersecting_pairs, union_of_balls_distance  # noqa: E402

SWEEPS = {"bend": np.arange(30, 136, 1), "twist": np.arange(0, 181, 2)}
CHECKS = {"bend": (45, 90, 135), "twist": (90, 180)}


def main(tag, opts):
    cache_dir = pathlib.Path(os.environ.get("CACHE", "/tmp/dgmesh_s30"))
    cache_dir.mkdir(parents=True, exist_ok=True)
    models = os.environ.get("MODELS", "capsule,camel,armadillo").split(",")
    out = {}
    for model, V, F, (heads, tails), bone, bend_axis in _joint_cases(False):
        name = model.split()[0]
        if name not in models:
            continue
        V, F = np.asarray(V, float), np.asarray(F)
        e = float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean())
        twist_axis = tuple((tails[bone] - heads[bone]) / np.linalg.norm(tails[bone] - heads[bone]))
        cache = cache_dir / f"{name}.pkl"
        if cache.exists():
            res = pickle.loads(cache.read_bytes())
        else:
            poses = [(bone, bend_axis if s == "bend" else twist_axis, np.radians(float(a)))
                     for s, angles in SWEEPS.items() for a in angles]
            res = armature_poses(V, F, heads, tails, poses)[0]
            cache.write_bytes(pickle.dumps(res))
        rest, W = res["rest"], res["W"]
        b0 = bone_distance(V, rest, rest, heads, tails)
        affected = moving_vertices(W, bone, b0)
        for path in os.environ.get("PATHS", "layer").split(","):
            faces = min(5000, len(F) // 2) if path == "layer" else len(F) + 1
            rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=faces, bone_heads=heads, bone_tails=tails)
            r = np.asarray(rig.radii)
            f_rest = union_of_balls_distance(V, rig.skeleton_vertices, r)
            first = 0
            for sweep, angles in SWEEPS.items():
                X = np.asarray([rig.deform(res[f"pose{p}"], **opts) for p in range(first, first + len(angles))])
                acc = path_jumps(X, e)
                if os.environ.get("VERBOSE"):
                    bad = np.where(acc.max(1) > 1)[0]
                    print(tag, name, sweep, " ".join(f"{angles[k + 1]}:{acc[k].max():.1f}/{int((acc[k] > 1).sum())}"
                                                     for k in bad))
                cells = [f"{name:9s} {path:5s} {sweep:5s} jump frames {int((acc.max(1) > 1).sum()):3d} max {acc.max():6.2f}"]
                for a in CHECKS[sweep]:
                    k = int(np.where(angles == a)[0][0])
                    pose, dqs = res[f"pose{first + k}"], res[f"dqs{first + k}"]
                    ours, n_dqs = len(self_intersecting_pairs(X[k], F)), len(self_intersecting_pairs(dqs, F))
                    ratio = min_bone_ratio(X[k], rest, pose, heads, tails, b0, affected)
                    ok = all(joint_bar(ours, n_dqs, ratio))
                    Sp = rig.skeleton_pose(pose)
                    go = union_of_balls_distance(X[k], Sp, r) - f_rest
                    gd = union_of_balls_distance(dqs, Sp, r) - f_rest
                    t = np.sum(go ** 2) / max(np.sum(gd ** 2), 1e-30)
                    cells.append(f"{a}: {ours}/{n_dqs} {ratio:.3f} t{t:.2f} {go.max() / e:.2f}/{go.min() / e:.2f}"
                                 f"({gd.max() / e:.2f}/{gd.min() / e:.2f}){'' if ok else '*'}")
                    out[f"{model}|{path}|{sweep} {a}"] = dict(pairs=ours, dqs=n_dqs, ratio=ratio, t=t, bar=ok)
                out[f"{model}|{path}|{sweep}|jumps"] = dict(frames=int((acc.max(1) > 1).sum()), max=float(acc.max()))
                first += len(angles)
                print(tag, " | ".join(cells), flush=True)
    met = [v["bar"] for v in out.values() if "bar" in v]
    print(tag, "bar met:", sum(met), "of", len(met))
    (cache_dir / f"variants_{tag}.json").write_text(json.dumps(out))


if __name__ == "__main__":
    opts = {}
    for a in sys.argv[2:]:
        k, v = a.split("=")
        opts[k] = float(v) if "." in v else int(v)
    main(sys.argv[1], opts)
