"""Skeletal deformation workloads (thesis chapter 6): thickness quality against linear blend
skinning and dual-quaternion skinning on a capsule, and bind / per-pose speed.

    /usr/bin/python3 bench/run.py skeletal_quality skeletal_speed skeletal_blender skeletal_bend_twist
        skeletal_blend_width

skeletal_quality computes LBS and DQS in numpy with the same weights (the formulas of Blender's
Armature modifier without / with Preserve Volume); skeletal_blender runs Blender's modifier itself
(bench/workloads/_skeletal_blender.py) and renders the poses side by side.
"""

import json
import pathlib
import tempfile
import time

import numpy as np

import dgmesh
from bench.common import IMAGES, cgal_mesh, interleaved_medians, loop_subdivide, median_time, run_blender, table
from bench.workloads.skeletal_limb import part_overlap
from dgmesh.skeletal import capsule, gaussian_bone_weights, self_intersecting_pairs, skeletal_subspace_deform


def _bone(head):
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (0, -1, 0), (1, 0, 0), (0, 0, 1), head
    return m


def _rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    return m


def _quat(R):
    w = np.sqrt(max(0.0, 1 + np.trace(R))) / 2
    if w > 1e-6:
        return np.array([w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)])
    i = np.argmax(np.diag(R))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = np.sqrt(max(0.0, 1 + R[i, i] - R[j, j] - R[k, k])) * 2
    q = np.zeros(4)
    q[i + 1] = s / 4
    q[0] = (R[k, j] - R[j, k]) / s
    q[j + 1] = (R[j, i] + R[i, j]) / s
    q[k + 1] = (R[k, i] + R[i, k]) / s
    return q


def _qmul(a, b):
    w1, v1, w2, v2 = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([w1 * w2 - np.sum(v1 * v2, -1, keepdims=True), w1 * v2 + w2 * v1 + np.cross(v1, v2)], -1)


def dqs(P, W, rest, pose):
    """Dual-quaternion skinning (Kavan et al.; Blender's Preserve Volume)."""
    B = len(rest)
    q0, qe = np.zeros((B, 4)), np.zeros((B, 4))
    for j in range(B):
        A = pose[j] @ np.linalg.inv(rest[j])
        q0[j] = _quat(A[:3, :3])
        qe[j] = 0.5 * _qmul(np.r_[0, A[:3, 3]], q0[j])
    sign = np.where(q0 @ q0[np.argmax(W, 1)].T < 0, -1, 1)  # unused for 2 bones beyond alignment
    ref = q0[np.argmax(W, 1)]
    s = np.sign(np.einsum("bk,nk->nb", q0, ref))
    s[s == 0] = 1
    Q0 = np.einsum("nb,nb,bk->nk", W, s, q0)
    Qe = np.einsum("nb,nb,bk->nk", W, s, qe)
    n = np.linalg.norm(Q0, axis=1, keepdims=True)
    Q0, Qe = Q0 / n, Qe / n
    w, v = Q0[:, :1], Q0[:, 1:]
    rot = P + 2 * np.cross(v, np.cross(v, P) + w * P)
    t = 2 * (Q0[:, :1] * Qe[:, 1:] - Qe[:, :1] * Q0[:, 1:] + np.cross(Q0[:, 1:], Qe[:, 1:]))
    del sign
    return rot + t


def _seg(P, a, b):
    ab = b - a
    t = np.clip((P - a) @ ab / (ab @ ab), 0, 1)
    return np.linalg.norm(a + t[:, None] * ab - P, axis=1)


def _bone_dist(X, rest, pose, heads, tails):
    d = []
    for j in range(len(rest)):
        A = pose[j] @ np.linalg.inv(rest[j])
        d.append(_seg(X, A[:3, :3] @ heads[j] + A[:3, 3], A[:3, :3] @ tails[j] + A[:3, 3]))
    return np.min(d, 0)


def _volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def capsule_bones():
    """The capsules' two bones, (-3.5,0,0)-(0,0,0)-(3.5,0,0): their rest frames, heads and tails."""
    rest = np.array([_bone((-3.5, 0, 0)), _bone((0, 0, 0))])
    return rest, np.array([[-3.5, 0, 0], [0, 0, 0.0]]), np.array([[0, 0, 0], [3.5, 0, 0.0]])


def quality(quick):
    V, F = capsule(0.5, 6.0, 48 if not quick else 32, 8, 96 if not quick else 48)
    rest, heads, tails = capsule_bones()
    weight_sets = {
        "gaussian (sigma 0.1)": gaussian_bone_weights(V, heads, tails, 0.1),
        "linear ramp over [-0.5, 0.5]": np.c_[1 - np.clip(V[:, 0] + 0.5, 0, 1), np.clip(V[:, 0] + 0.5, 0, 1)],
    }
    poses = {"bend 90": np.array([rest[0], _rot((0, 0, 1), np.pi / 2) @ rest[1]]),
             "twist 180": np.array([rest[0], _rot((1, 0, 0), np.pi) @ rest[1]])}
    b0 = _bone_dist(V, rest, rest, heads, tails)
    ok = b0 > 1e-9
    vol0 = _volume(V, F)
    rows, data = [], {}
    for wname, W in weight_sets.items():
        # The method itself on the whole mesh (no multiresolution layer: the capsule has more than the
        # default 5000 faces, and the decimated control mesh's own error would dominate); the
        # 5000-face multires variant is one extra row.
        rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=len(F) + 1)
        rig_mr = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=5000)
        for pname, pose in poses.items():
            _, Sd = rig.deform_control(pose)
            results = {
                "rest pose (reference)": V,
                "LBS": skeletal_subspace_deform(V, W, rest, pose),
                "DQS": dqs(V, W, rest, pose),
                "ours, 2 fairing steps + projection": rig.deform(pose, fairing_steps=2),
                "ours without the joint fillet (joint_fillet=0; the default before session 35)": rig.deform(
                    pose, fairing_steps=2, joint_fillet=0),
                "ours, 2 fairing steps, no projection": rig.deform(pose, fairing_steps=2, projection=0),
                "ours, 4 fairing steps, no projection": rig.deform(pose, fairing_steps=4, projection=0),
                "ours, no fairing": rig.deform(pose, fairing_steps=0),
                "basic (6.3)": rig.deform(pose, method="basic"),
                "ours via multires (5000-face control), 2 fairing steps + projection": rig_mr.deform(pose),
            }
            # eq. 6.13 at rest: the mesh is not exactly on the union of its medial balls (balls of
            # neighbours poke out), so sum f^2 has a floor; f - f_rest isolates the pose's change.
            f_rest = dgmesh.union_of_balls_distance(V, rig.skeleton_vertices, rig.radii)
            for mname, X in results.items():
                centers = rig.skeleton_vertices if mname.startswith("rest") else Sd
                f = dgmesh.union_of_balls_distance(X, centers, rig.radii)
                r = _bone_dist(X, rest, pose if not mname.startswith("rest") else rest, heads, tails)[ok] / b0[ok]
                row = [wname, pname, mname, float((f**2).sum()), float(((f - f_rest)**2).sum()), float(r.min()),
                       float(r.mean()), float(_volume(X, F) / vol0)]
                rows.append(row)
                data[f"{wname}|{pname}|{mname}"] = dict(zip(["sum_f2", "sum_df2", "min_ratio", "mean_ratio",
                                                             "volume_ratio"], row[3:]))
    md = ["### Skeletal deformation quality (capsule r 0.5, length 6, %d vertices, 2 bones)" % len(V), "",
          "Thickness error sum f^2 of eq. 6.13 against our posed skeletal mesh (exact union of balls; with the "
          "joint fillet since session 35, whose arc cuts the bend's corner: the bone clearance keeps the outer side "
          "at its distance to the bones, beyond that skeleton's balls, and every method's error against it grows), and "
          "sum (f - f_rest)^2, its change from the rest pose (the rest mesh itself has sum f^2 > 0); ratio of each vertex's "
          "distance to the bone segments after / before; volume ratio. LBS and DQS are numpy re-implementations "
          "with the same weights (not Blender's modifier run). Ours binds the whole mesh (control_faces > F) "
          "except the 'via multires' row (decimated 5000-face control mesh, the speed benchmark's setting). DQS is "
          "exact for a pure twist of a straight tube (a rigid turn about the axis), so its twist error sits at the "
          "rest floor. Every 'ours' row with fairing includes the fold guard (issue 33, `fold_guard` 50, the default "
          "since session 26; it smooths the faces the thickness steps turn over).", "",
          table(["weights", "pose", "method", "sum f^2", "sum (f-f_rest)^2", "min ratio", "mean ratio", "volume"],
                rows), "",
          "`/usr/bin/python3 bench/run.py skeletal_quality`"]
    return {"markdown": "\n".join(md), "data": data}


def speed_capsule(levels=2):
    """skeletal_speed's capsule (issue 33's 178K-vertex case at 2 levels): r 0.5, length 6, 80 x 10 x
    120, Loop-subdivided `levels` times, on the bones (-3.5,0,0)-(0,0,0)-(3.5,0,0). Returns V, F, the
    bones' rest frames, heads, tails."""
    V0, F0 = capsule(0.5, 6.0, 80, 10, 120)
    V, F = loop_subdivide(V0, F0, levels)
    return (V, F, *capsule_bones())


def ramp_weights(V):
    """The narrow blend of skeletal_live's capsule: linear over x in [-0.5, 0.5] between the two bones."""
    t = np.clip(V[:, 0] + 0.5, 0, 1)
    return np.c_[1 - t, t]


def speed(quick):
    V, F, rest, _, _ = speed_capsule(1 if quick else 2)
    t0 = time.perf_counter()
    rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
    t_bind = time.perf_counter() - t0
    pose = np.array([rest[0], _rot((0, 0, 1), np.pi / 3) @ rest[1]])
    t_ctrl, _ = median_time(lambda: rig.deform_control(pose), repeats=7)
    t_full, _ = median_time(lambda: rig.deform(pose), repeats=7)
    t_nof, _ = median_time(lambda: rig.deform(pose, fairing_steps=0), repeats=7)
    out = np.empty((rig.n_vertices, 3))
    t_buf, _ = median_time(lambda: rig.deform(pose, out=out), repeats=7)
    out32 = np.empty((rig.n_vertices, 3), dtype=np.float32)
    # With and without the fold guard (issue 33, on by default from this run), interleaved.
    t_buf32, t_noguard32 = interleaved_medians([lambda: rig.deform(pose, out=out32),
                                                lambda: rig.deform(pose, out=out32, fold_guard=0)])
    # With the untangling (issue 33, off by default): its cost at this size, and the crossing pairs
    # over the whole dense mesh without / with it.
    t_unt32, _ = median_time(lambda: rig.deform(pose, out=out32, untangle_iterations=20), repeats=3)
    pairs_off = len(self_intersecting_pairs(rig.deform(pose), F))
    pairs_on = len(self_intersecting_pairs(rig.deform(pose, untangle_iterations=20), F))
    pairs_noguard = len(self_intersecting_pairs(rig.deform(pose, fold_guard=0), F))
    # The dense part alone: reconstruct from a deformed control mesh into the float32 buffer.
    Xc, _ = rig.deform_control(pose)
    a = rig.to_arrays()
    mr = dgmesh.Multires.from_arrays({
        "control_vertices": a["mr_control_V"], "control_faces": a["mr_control_F"], "level": a["mr_level"],
        "base_face": a["mr_face"], "base_st": a["mr_st"], "displacement": a["mr_disp"]})
    t_rec32, _ = median_time(lambda: mr.reconstruct(Xc, out=out32), repeats=15)
    # CPU seconds per call (all threads): comparable across runs on a shared machine.
    def cpu_ms(fn, n=15):
        fn()
        c0 = time.process_time()
        for _ in range(n):
            fn()
        return 1e3 * (time.process_time() - c0) / n
    cpu_ctrl = cpu_ms(lambda: rig.deform_control(pose))
    cpu_buf32 = cpu_ms(lambda: rig.deform(pose, out=out32))
    rows = [[len(V), len(F), rig.n_control, len(rig.control_faces), t_bind, 1e3 * t_ctrl, 1e3 * t_rec32, 1e3 * t_nof,
             1e3 * t_full, 1e3 * t_buf, 1e3 * t_buf32, cpu_ctrl, cpu_buf32, 1e3 * t_noguard32, 1e3 * t_unt32,
             pairs_off, pairs_noguard, pairs_on]]
    live = run_blender(pathlib.Path(__file__).with_name("_skeletal_live.py"), [1 if quick else 2])
    md = ["### Skeletal deformation speed", "",
          table(["dense V", "dense F", "control V", "control F", "bind s", "control deform ms (2 fair)",
                 "dense reconstruct ms (float32)", "full deform ms (no fair)", "full deform ms (2 fair)",
                 "full deform ms (2 fair, float64 buffer)", "full deform ms (2 fair, float32 buffer)",
                 "CPU ms control deform", "CPU ms full deform (float32 buffer)",
                 "full deform ms (float32 buffer, fold_guard=0)",
                 "full deform ms (float32 buffer, untangle_iterations=20)", "crossing pairs (default)",
                 "crossing pairs (fold_guard=0)", "crossing pairs (untangle_iterations=20)"], rows),
          "", "Capsule Loop-subdivided; control mesh 5000 faces; wall-clock medians (7 runs, 15 for the reconstruct) "
          "(the float32 buffer with and without the fold guard: 15 each, interleaved) "
          "and process CPU time per call (all threads, including OpenMP's spin-waiting; the control deform "
          "runs on the OpenMP threads). Targets: bind <= 10 s for 170K vertices, per pose (native deform + dense reconstruction) "
          "<= 20 ms. The defaults include the fold guard (issue 33; `fold_guard=0`: without it, the default "
          "until this run). The untangling column: `untangle_iterations=20` (median of 3); the pairs: "
          "`dgmesh.skeletal.self_intersecting_pairs` over the whole dense mesh. The float32 buffer is what the live update hands to Blender "
          "(`rig.deform(pose, out=np.empty((n, 3), np.float32))`).", "",
          "Live in Blender (`dgmesh.skeletal_bind` operator, then `scene.frame_set` over 20 keyframed frames, median): "
          "%d vertices, bind %.2f s, frame_set %.1f ms (%.1f frames per second), of which our deform %.1f ms "
          "(%d deforms for %d frames); the rest is the write to the hidden helper object and Blender's own evaluation of the mesh (split in skeletal_live). Target <= 60 ms."
          % (live["V"], live["bind_s"], live["frame_ms"], 1e3 / live["frame_ms"], live["deform_ms"], live["n_deform"],
             live["n_frames"]), "",
          "`/usr/bin/python3 bench/run.py skeletal_speed`"]
    data = dict(zip(["V", "F", "control_V", "control_F", "bind_s", "control_ms", "reconstruct_f32_ms", "full_nofair_ms",
                     "full_ms", "full_buffer_ms", "full_buffer_f32_ms", "control_cpu_ms", "full_buffer_f32_cpu_ms",
                     "full_buffer_f32_noguard_ms", "full_buffer_f32_untangle_ms", "pairs_default", "pairs_noguard",
                     "pairs_untangle"],
                    rows[0]))
    data["blender_live"] = live
    return {"markdown": "\n".join(md), "data": data}


BEND_TWIST = [(60, 45), (60, -45), (90, 45), (90, -45), (90, 90), (45, 90)]


def bend_twist(quick):
    """A joint bent and twisted at once (issue 33, session 36): skeletal_speed's capsule bound without
    weights (through its 5000-face control mesh), the second bone bent about z, then twisted about its
    own axis."""
    V, F, rest, heads, tails = speed_capsule(1 if quick else 2)
    rig = dgmesh.SkeletalRig.bind(V, F, rest, None, control_faces=5000)
    # DQS with the rig's recipe for the dense vertices: Gaussian weights of the distance to the bones,
    # sigma a fifth of the median medial radius (the rig weights its skeletal points so).
    W = gaussian_bone_weights(V, heads, tails, 0.2 * float(np.median(rig.radii)))
    b0 = _bone_dist(V, rest, rest, heads, tails)
    ok = b0 > 1e-9
    vol0 = _volume(V, F)
    methods = {"ours (defaults)": {}, "ours, twist shared by the weights (ring_twist=False)": {"ring_twist": False},
               "ours with follow_twist": {"follow_twist": True}}
    rows, data = [], {}
    for b, t in BEND_TWIST:
        pose = np.array([rest[0], _rot((0, 0, 1), np.radians(b)) @ _rot((1, 0, 0), np.radians(t)) @ rest[1]])
        results = {name: rig.deform(pose, **kw) for name, kw in methods.items()}
        results["DQS (numpy, Blender's Preserve Volume formula)"] = skeletal_subspace_deform(V, W, rest, pose,
                                                                                           dual_quaternion=True)
        for name, X in results.items():
            cell = dict(pairs=len(self_intersecting_pairs(X, F)),
                        ratio=float((_bone_dist(X, rest, pose, heads, tails)[ok] / b0[ok]).min()),
                        volume=float(_volume(X, F) / vol0))
            data[f"bend {b} twist {t}|{name}"] = cell
            rows.append([f"bend {b}, twist {t}", name, cell["pairs"], "%.3f" % cell["ratio"], "%.4f" % cell["volume"]])
    md = ["### A joint bent and twisted at once (issue 33)", "",
          table(["pose (degrees)", "method", "self-intersecting triangle pairs", "min bone ratio", "volume"], rows), "",
          "skeletal_speed's capsule (%d vertices; 5000-face control mesh), bound without weights (the rig's Gaussian "
          "weights of its skeletal points, which vary around the limb on the decimated control mesh), the second bone "
          "bent about z and twisted about its own axis. The joint fillet turns each cross-section of its band by the "
          "vertex's share of the child's twist, from the ring weights since session 36 (ring_twist=False: from the "
          "weights, which was the default's share before on the poses whose twist does not dominate the swing: all "
          "but the last two). Pairs: `dgmesh.skeletal.self_intersecting_pairs` over the whole mesh; min bone ratio: "
          "distance to the nearest posed bone segment, posed / rest; DQS with the rig's recipe applied to the dense "
          "vertices (Gaussian weights, sigma a fifth of the median medial radius)." % len(V), "",
          "`/usr/bin/python3 bench/run.py skeletal_bend_twist`"]
    return {"markdown": "\n".join(md), "data": data}


WIDTH_RADII, WIDTH_SIGMAS, WIDTH_BENDS = (0.35, 0.5, 0.75, 1.0), (0.2, 0.5, 1.0), (30, 60, 90, 105, 120, 135)


def blend_width(quick):
    """Issue 33's joint bar over the width of the weight blend (session 37): skeletal_joints uses
    Blender's automatic weights, which blend over about 1.3 limb radii on both sides of a joint; painted
    weights are often wider. Capsules (48 x 8 x 96, two bones of 3.5) of several radii with Gaussian
    weights of the distance to the bones (sigma in scene units), bent about z."""
    radii, sigmas, bends = ((0.5, 1.0), (0.2, 1.0), (60, 90, 120)) if quick else (WIDTH_RADII, WIDTH_SIGMAS,
                                                                                  WIDTH_BENDS)
    rest, heads, tails = capsule_bones()
    methods = {"ours, whole mesh": (None, {}), "ours via multires": (0.5, {}),
               "ours, whole mesh, untangle 10": (None, {"untangle_iterations": 10})}
    rows, data, met = [], {}, {m: 0 for m in methods}
    for r in radii:
        V, F = capsule(r, 6.0, 48, 8, 96)
        b0 = _bone_dist(V, rest, rest, heads, tails)
        ok = b0 > 1e-9
        for sigma in sigmas:
            W = gaussian_bone_weights(V, heads, tails, sigma)
            rigs = {f: dgmesh.SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails,
                                               control_faces=len(F) + 1 if f is None else int(f * len(F)))
                    for f in {f for f, _ in methods.values()}}
            for bend in bends:
                pose = np.array([rest[0], _rot((0, 0, 1), np.radians(bend)) @ rest[1]])
                D = skeletal_subspace_deform(V, W, rest, pose, dual_quaternion=True)
                dq = len(self_intersecting_pairs(D, F))
                dq_ratio = float((_bone_dist(D, rest, pose, heads, tails)[ok] / b0[ok]).min())
                data[f"r {r} sigma {sigma} bend {bend}|DQS"] = dict(pairs=dq, ratio=dq_ratio)
                row = [r, sigma, bend, "%d (%.3f)" % (dq, dq_ratio)]
                for name, (f, kw) in methods.items():
                    X = rigs[f].deform(pose, **kw)
                    n = len(self_intersecting_pairs(X, F))
                    ratio = float((_bone_dist(X, rest, pose, heads, tails)[ok] / b0[ok]).min())
                    bar = n < max(dq, 1) and ratio >= 0.9
                    met[name] += bar
                    data[f"r {r} sigma {sigma} bend {bend}|{name}"] = dict(pairs=n, dqs=dq, ratio=ratio, bar=bar)
                    row.append("%d (%.3f)%s" % (n, ratio, "" if bar else " *"))
                rows.append(row)
    cells = len(radii) * len(sigmas) * len(bends)
    md = ["### Issue 33's joint bar over the width of the weight blend", "",
          table(["radius", "sigma", "bend (degrees)", "DQS"] + list(methods), rows), "",
          table(["ours", "cells meeting the bar"], [[m, f"{k} of {cells}"] for m, k in met.items()]), "",
          "Capsules of radius r (48 x 8 x 96, bones (-3.5, 0, 0)-(0, 0, 0)-(3.5, 0, 0)) with Gaussian weights of "
          "the distance to the bones (`dgmesh.skeletal.gaussian_bone_weights`, sigma in scene units: 0.2 blends "
          "over about one limb radius of 0.5 either side of the joint, 1.0 over most of both bones), the second bone "
          "bent about z. Each cell: self-intersecting triangle pairs over the whole mesh and, in brackets, the "
          "minimum ratio of the distance to the nearest posed bone segment, posed / rest; * misses issue 33's bar "
          "(fewer pairs than DQS, none where it has none; ratio >= 0.9). DQS: numpy, Blender's Preserve Volume "
          "formula, the same weights; it keeps no crossing in the wide blends' tight bends by collapsing the joint "
          "(its ratio in brackets). Through the multiresolution layer: a control mesh of half the faces.", "",
          "`/usr/bin/python3 bench/run.py skeletal_blend_width`"]
    return {"markdown": "\n".join(md), "data": data}


BLENDER_SCRIPT = pathlib.Path(__file__).with_name("_skeletal_blender.py")
RENDER_SCRIPT = pathlib.Path(__file__).with_name("_crest_render.py")


def _render(name, panels, **meta):
    """Panels side by side (Cycles CPU, no denoising) into bench/images/<name>."""
    arrays = {}
    for i, (V, F, C) in enumerate(panels):
        arrays[f"V{i}"], arrays[f"F{i}"], arrays[f"C{i}"] = V, F.astype(np.int32), C.astype(np.float32)
    IMAGES.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        inp = pathlib.Path(tmp) / "in.npz"
        np.savez(inp, meta=json.dumps(dict(meta, panels=len(panels))), **arrays)
        run_blender(RENDER_SCRIPT, [inp, IMAGES / name])
    return IMAGES / name


def _blender_case(model, V, F, heads, tails, W, quick, up, view):
    """Blender's Armature modifier (linear blend, Preserve Volume) against ours on one mesh and chain."""
    poses = {"bend 90": (0.0, 0.0, np.pi / 2), "twist 180": (0.0, np.pi, 0.0)}
    with tempfile.TemporaryDirectory() as tmp:
        inp, outp = pathlib.Path(tmp) / "in.npz", pathlib.Path(tmp) / "out.npz"
        np.savez(inp, V=V, F=F, W=W, heads=heads, tails=tails, poses=np.array(list(poses.values())))
        info = run_blender(BLENDER_SCRIPT, [inp, outp])
        res = dict(np.load(outp))
    rest = res["rest"]
    rig = dgmesh.SkeletalRig.bind(V, F, rest, W, control_faces=len(F) + 1)
    f_rest = dgmesh.union_of_balls_distance(V, rig.skeleton_vertices, rig.radii)
    b0 = _bone_dist(V, rest, rest, heads, tails)
    ok = b0 > 1e-9
    vol0 = _volume(V, F)
    rows, data, images, collisions = [], {}, [], []
    # Whether the pose drives one part into the other (any deformer then has to give way there): the
    # vertices of the still part (all weight on the first bone) inside the medial balls of the moved
    # part (all weight on the last bone; the whole mesh is the control mesh, so skeletal vertex i is
    # vertex i's) posed rigidly, as no blending can change.
    still, moved = W[:, 0] == 1, W[:, -1] == 1
    for p, pname in enumerate(poses):
        pose = res[f"pose{p}"]
        fc, _ = part_overlap(rig, V, still, moved, pose[-1] @ np.linalg.inv(rest[-1]))
        collisions.append((model, pname, int((fc < 0).sum()), int(still.sum()),
                           float(max(0.0, -fc.min()) / np.median(rig.radii))))
        data[f"{model}|{pname}|collision"] = dict(zip(["inside", "still_vertices", "depth_over_median_radius"],
                                                      collisions[-1][2:]))
        _, Sd = rig.deform_control(pose)
        results = {"Blender Armature, linear blend": res[f"lbs{p}"],
                   "Blender Armature, Preserve Volume": res[f"dqs{p}"],
                   "ours (2 fairing steps + projection)": rig.deform(pose),
                   "ours without the fold guard (fold_guard=0; the default until this run)": rig.deform(
                       pose, fold_guard=0),
                   "ours with the untangling (untangle_iterations=20; issue 33)": rig.deform(pose, untangle_iterations=20),
                   "ours, thickness following the twist (follow_twist; issue 33)": rig.deform(pose, follow_twist=True),
                   "ours, follow_twist and the untangling": rig.deform(pose, follow_twist=True,
                                                                         untangle_iterations=20),
                   "ours without the joint fillet (joint_fillet=0; the default before session 35)": rig.deform(
                       pose, joint_fillet=0),
                   "ours on the blend's skeleton (integrate_skeleton=False, joint_fillet=0; the default before "
                   "session 33)": rig.deform(pose, integrate_skeleton=False, joint_fillet=0)}
        panels = []
        for mname, X in results.items():
            f = dgmesh.union_of_balls_distance(X, Sd, rig.radii)
            n_pairs = len(self_intersecting_pairs(X, F))
            r = _bone_dist(X, rest, pose, heads, tails)[ok] / b0[ok]
            row = [model, pname, mname, float((f ** 2).sum()), float(((f - f_rest) ** 2).sum()), float(r.min()),
                   float(r.mean()), float(_volume(X, F) / vol0), n_pairs]
            rows.append(row)
            data[f"{model}|{pname}|{mname}"] = dict(zip(["sum_f2", "sum_df2", "min_ratio", "mean_ratio",
                                                         "volume_ratio", "self_intersecting_pairs"], row[3:]))
            # Face colour: grey, red where the thickness changed (|f - f_rest| up to a fifth of the
            # median medial radius).
            t = np.clip(np.abs(f - f_rest)[F].mean(1) / (0.2 * np.median(rig.radii)), 0, 1)[:, None]
            C = (1 - t) * np.array([0.7, 0.7, 0.68]) + t * np.array([0.9, 0.05, 0.05])
            panels.append((X, F, C))
        name = "skeletal_%s_%s.png" % (model, pname.replace(" ", "_"))
        if not quick:
            _render(name, panels[:3], up=up, size=(900, 300), samples=16, view=view)
            images.append(name)
    return rows, data, images, info.get("blender", "?"), collisions


def blender_quality(quick):
    """Against Blender's own Armature modifier (linear blend and Preserve Volume): the capsule and,
    unless quick, the armadillo scan bent / twisted at the waist."""
    V, F = capsule(0.5, 6.0, 32 if quick else 48, 8, 48 if quick else 96)
    W = np.c_[1 - np.clip(V[:, 0] + 0.5, 0, 1), np.clip(V[:, 0] + 0.5, 0, 1)]
    _, heads, tails = capsule_bones()
    rows, data, images, version, collisions = _blender_case("capsule", V, F, heads, tails, W, quick, "Z",
                                                            (0.3, -1.0, 0.6))
    if not quick:
        V, F = cgal_mesh("armadillo")  # y up, feet at y = -54, ears at y = 97
        y = V[:, 1]
        t = np.clip((y - 0.0) / 20.0, 0, 1)  # ramp over the waist, y in [0, 20]
        W = np.c_[1 - t, t]
        r2, d2, i2, _, c2 = _blender_case("armadillo", V, F, np.array([[0, -54, 0], [0, 10, 0.0]]),
                                      np.array([[0, 10, 0], [0, 97, 0.0]]), W, quick, "Y", (0.2, -1.0, 0.25))
        rows, images, collisions = rows + r2, images + i2, collisions + c2
        data.update(d2)
    md = ["### Skeletal deformation vs Blender's Armature modifier", "",
          "Blender %s, Armature modifier on the same linear-ramp vertex groups, the last bone of the chain "
          "rotated (Euler YXZ) 90 degrees about its Z (bend) or 180 about its Y (twist); ours (2 fairing steps + "
          "projection) bound to the same bone matrices on the whole mesh (no multires). Capsule r 0.5, length 6, "
          "bones (-3.5,0,0)-(0,0,0)-(3.5,0,0), ramp over x in [-0.5, 0.5]; armadillo (CGAL data, 26002 vertices), "
          "bones (0,-54,0)-(0,10,0)-(0,97,0), ramp over y in [0, 20] (the waist). Metrics as in skeletal_quality, "
          "against our posed skeletal mesh (with the joint fillet on a bent joint: its arc cuts the joint's "
          "corner, so every method's error against it grows where the surface keeps its distance to the bones)." %
          version, "",
          table(["mesh", "pose", "method", "sum f^2", "sum (f-f_rest)^2", "min ratio", "mean ratio", "volume",
                 "self-intersecting triangle pairs"], rows), "",
          "Self-intersecting triangle pairs: `dgmesh.skeletal.self_intersecting_pairs` over the whole mesh "
          "(pairs sharing no vertex, an edge of one through the other's interior).",
          "", "Does the pose drive the moved part into the still one? Vertices of the still part (all weight on "
          "the first bone) inside the medial balls of the moved part (all weight on the last bone) posed rigidly, "
          "which no deformer changes; depth over the median medial radius. A few vertices at a negligible depth "
          "are the joint itself; where many lie deep inside, the parts collide and every deformer's minimum "
          "ratio measures the collision, not a thinning (the armadillo's 90-degree bend swings the torso "
          "sideways into the hip and thigh):", "",
          table(["mesh", "pose", "still-part vertices inside the posed moved part", "still-part vertices",
                 "deepest / median radius"], collisions), ""]
    for name in images:
        md += [f"![{name}](../images/{name})", "",
               "Left to right: linear blend, Preserve Volume, ours; red = thickness change |f - f_rest| "
               "(a fifth of the median medial radius = full red).", ""]
    md.append("`/usr/bin/python3 bench/run.py skeletal_blender`")
    return {"markdown": "\n".join(md), "data": data}


WORKLOADS = {"skeletal_quality": quality, "skeletal_speed": speed, "skeletal_blender": blender_quality,
             "skeletal_bend_twist": bend_twist, "skeletal_blend_width": blend_width}
