"""Close-up renders of issue 33's crease, one PNG per pose, left to right LBS, DQS, ours without the
untangling (untangle_iterations=0) and ours with it (UNTANGLE iterations), the faces of
self-intersecting pairs in red, into bench/images (Blender, Cycles CPU):

- capsule: the 64 x 10 x 128 capsule of bench skeletal_limb (Gaussian weights, the rig's own, as in
  bench/tools/skeletal_crease_probe.py; LBS / DQS = skeletal_subspace_deform with the same weights),
  whole mesh, bends of 45 / 90 / 135 degrees about z and twists of 90 / 180 about x, the faces within
  1.6 of the joint: skeletal_untangle_capsule_<pose>.png;
- camel, armadillo: bench skeletal_limb's legs (Blender's automatic weights and Armature modifier,
  bench/workloads/_skeletal_limb.py), whole mesh, the lower bone bent 90 degrees, the faces of the
  leg within a radius of the knee: skeletal_untangle_<model>_bend_90.png.

    /usr/bin/python3 bench/tools/skeletal_untangle_render.py [capsule] [camel] [armadillo]
"""
import pathlib
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import cgal_mesh, run_blender  # noqa: E402
from bench.workloads.skeletal import _render  # noqa: E402
from bench.workloads.skeletal_limb import ARMADILLO_BONES, CAMEL_BONES, LIMB_SCRIPT  # noqa: E402
from dgmesh.skeletal import capsule, self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402
from skeletal_crease_probe import HEADS, REST, TAILS, rot  # noqa: E402

UNTANGLE = 20


def panels(V, F, shown, results, label):
    """Mesh pieces of the shown faces, crossing pairs' faces red; prints the pair counts."""
    Fn = F[shown]
    used = np.unique(Fn)
    remap = -np.ones(len(V), int)
    remap[used] = np.arange(len(used))
    out, counts = [], []
    for X in results:
        hit = np.zeros(len(F), bool)
        P = self_intersecting_pairs(X, F)
        hit[P.ravel()] = True
        counts.append(len(P))
        C = np.where(hit[shown][:, None], np.array([0.9, 0.05, 0.05]), np.array([0.7, 0.7, 0.68]))
        out.append((X[used], remap[Fn], C))
    print(label, "pairs (whole mesh) LBS / DQS / ours untangle 0 / ours untangle %d:" % UNTANGLE,
          " / ".join(map(str, counts)), flush=True)
    return out


def capsule_renders():
    V, F = capsule(0.5, 6.0, 64, 10, 128)
    rig = dgmesh.SkeletalRig.bind(V, F, REST, None, bone_heads=HEADS, bone_tails=TAILS, control_faces=len(F) + 1)
    near = np.linalg.norm(V[F].mean(1), axis=1) < 1.6
    poses = {"bend_45": ((0, 0, 1), 45), "bend_90": ((0, 0, 1), 90), "bend_135": ((0, 0, 1), 135),
             "twist_90": ((1, 0, 0), 90), "twist_180": ((1, 0, 0), 180)}
    for name, (axis, angle) in poses.items():
        pose = np.array([REST[0], rot(axis, np.radians(angle)) @ REST[1]])
        results = (skeletal_subspace_deform(V, rig.weights, REST, pose),
                   skeletal_subspace_deform(V, rig.weights, REST, pose, dual_quaternion=True),
                   rig.deform(pose, untangle_iterations=0), rig.deform(pose, untangle_iterations=UNTANGLE))
        # Bends: seen from the inner side of the bend; twists: from the side.
        view = (-1.0, 1.0, 0.35) if name.startswith("bend") else (0.3, -1.0, 0.6)
        print(_render(f"skeletal_untangle_capsule_{name}.png", panels(V, F, near, results, f"capsule {name}"),
                      up="Z", size=(1200, 320), samples=16, view=view, gap=0.6))


def leg_render(which):
    mesh, (heads, tails), bend_axis, radius = {"camel": ("camel", CAMEL_BONES, (1, 0, 0), 0.09),
                                               "armadillo": ("armadillo", ARMADILLO_BONES, (-1, 0, 0), 14.0)}[which]
    V, F = cgal_mesh(mesh)
    with tempfile.TemporaryDirectory() as tmp:
        inp, outp = pathlib.Path(tmp) / "in.npz", pathlib.Path(tmp) / "out.npz"
        np.savez(inp, V=V, F=F, heads=heads, tails=tails, poses=np.array([[2, *bend_axis, np.pi / 2]], dtype=float))
        run_blender(LIMB_SCRIPT, [inp, outp])
        res = dict(np.load(outp))
    rest, W, pose = res["rest"], res["W"], res["pose0"]
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails, control_faces=len(F) + 1)
    # The knee: the faces of this leg (x > 0) within `radius` of the lower bone's head.
    C = V[F].mean(1)
    shown = (C[:, 0] > 0) & (np.linalg.norm(C - heads[2], axis=1) < radius)
    results = (res["lbs0"], res["dqs0"], rig.deform(pose, untangle_iterations=0),
               rig.deform(pose, untangle_iterations=UNTANGLE))
    print(_render(f"skeletal_untangle_{which}_bend_90.png", panels(V, F, shown, results, f"{which} bend_90"),
                  up="Y", spin=-90.0, size=(1200, 420), samples=16, view=(0.0, -1.0, 0.15), gap=0.3))


if __name__ == "__main__":
    which = sys.argv[1:] or ["capsule", "camel", "armadillo"]
    if "capsule" in which:
        capsule_renders()
    for leg in ("camel", "armadillo"):
        if leg in which:
            leg_render(leg)
