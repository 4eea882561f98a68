"""Close-up renders of issue 33's joint creases with today's defaults, one PNG per mesh and pose,
left to right: LBS, DQS, ours on the whole mesh, ours through the multiresolution layer (5000-face
control mesh: the Skeletal Bind operator's path above 5000 faces) and the same with Untangle
Creases (untangle_iterations=UNTANGLE), the faces of self-intersecting pairs in red, into
bench/images/skeletal_crease_<mesh>_<pose>.png (Blender, Cycles CPU). Prints each panel's pair count
over the whole mesh.

- capsule: the 64 x 10 x 128 capsule of bench/tools/skeletal_crease_probe.py (probe_rigs: Gaussian
  weights, the rig's own; LBS / DQS = skeletal_subspace_deform with the same weights), the faces
  within 1.6 of the joint; bends seen from their inner side, twists from the side;
- camel, armadillo: bench skeletal_limb's legs (Blender's automatic weights and Armature modifier,
  bench/workloads/_skeletal_limb.py), the leg's faces within a radius of the knee.

Poses: the lower bone bent 45 / 90 / 135 degrees, twisted 90 / 180 degrees about its own axis.

    /usr/bin/python3 bench/tools/skeletal_crease_render.py [capsule] [camel] [armadillo]
"""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon"), str(ROOT / "bench" / "tools")]
import numpy as np  # noqa: E402

import dgmesh  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402
from bench.workloads.skeletal import _render  # noqa: E402
from bench.workloads.skeletal_limb import ARMADILLO_BONES, CAMEL_BONES, armature_poses  # noqa: E402
from dgmesh.skeletal import capsule, self_intersecting_pairs, skeletal_subspace_deform  # noqa: E402
from skeletal_crease_probe import REST, probe_poses, probe_rigs  # noqa: E402

UNTANGLE = 20
CONTROL = 5000  # as probe_rigs
LABELS = ("LBS", "DQS", "ours whole", "ours via multires", f"ours via multires, untangle {UNTANGLE}")
ANGLES = {"bend_45": 45, "bend_90": 90, "bend_135": 135, "twist_90": 90, "twist_180": 180}


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
    print(label, "pairs (whole mesh)", " / ".join(f"{n} {c}" for n, c in zip(LABELS, counts)), flush=True)
    return out


def ours(whole, layered, pose):
    return (whole.deform(pose), layered.deform(pose), layered.deform(pose, untangle_iterations=UNTANGLE))


def capsule_renders():
    V, F = capsule(0.5, 6.0, 64, 10, 128)
    rigs = probe_rigs(V, F)
    near = np.linalg.norm(V[F].mean(1), axis=1) < 1.6
    for name, R in probe_poses().items():
        pose = np.array([REST[0], R @ REST[1]])
        W = rigs["whole"].weights
        results = (skeletal_subspace_deform(V, W, REST, pose), skeletal_subspace_deform(V, W, REST, pose, dual_quaternion=True),
                   *ours(rigs["whole"], rigs["multires"], pose))
        # A bend's inner side, seen with the capsule turned half round (so that the panels, laid out
        # along x, read left to right); a twist from the side.
        view, spin = ((1.0, -1.0, 0.35), 180.0) if name.startswith("bend") else ((0.3, -1.0, 0.6), 0.0)
        name = name.replace(" ", "_")
        print(_render(f"skeletal_crease_capsule_{name}.png", panels(V, F, near, results, f"capsule {name}"),
                      up="Z", spin=spin, size=(1500, 320), samples=16, view=view, gap=0.6))


def leg_renders(which):
    mesh, (heads, tails), bend_axis, radius = {"camel": ("camel", CAMEL_BONES, (1, 0, 0), 0.09),
                                               "armadillo": ("armadillo", ARMADILLO_BONES, (-1, 0, 0), 14.0)}[which]
    V, F = cgal_mesh(mesh)
    axis = tuple((tails[2] - heads[2]) / np.linalg.norm(tails[2] - heads[2]))
    poses = [(2, bend_axis if name.startswith("bend") else axis, np.radians(angle)) for name, angle in ANGLES.items()]
    res = armature_poses(V, F, heads, tails, poses)[0]
    rest, W = res["rest"], res["W"]
    bind = dict(bone_heads=heads, bone_tails=tails)
    whole = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=len(F) + 1, **bind)
    layered = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=CONTROL, **bind)
    # The knee: the faces of this leg (x > 0) within `radius` of the lower bone's head.
    C = V[F].mean(1)
    shown = (C[:, 0] > 0) & (np.linalg.norm(C - heads[2], axis=1) < radius)
    for p, name in enumerate(ANGLES):
        pose = res[f"pose{p}"]
        results = (res[f"lbs{p}"], res[f"dqs{p}"], *ours(whole, layered, pose))
        print(_render(f"skeletal_crease_{which}_{name}.png", panels(V, F, shown, results, f"{which} {name}"),
                      up="Y", spin=-90.0, size=(1500, 420), samples=16, view=(0.0, -1.0, 0.15), gap=0.3))


if __name__ == "__main__":
    which = sys.argv[1:] or ["capsule", "camel", "armadillo"]
    if "capsule" in which:
        capsule_renders()
    for leg in ("camel", "armadillo"):
        if leg in which:
            leg_renders(leg)
