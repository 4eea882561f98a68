"""DG Mesh demo: a scanned model through the add-on's operators, rendered.

    blender --background --factory-startup --python-exit-code 1 \
        --python scripts/demo.py -- OUTDIR [--model bunny00] [--up Y|Z] [--steps a,b,...]

Needs the native module built (bash scripts/build.sh).  The model comes from
Debian's CGAL data (unpacked into $DGMESH_DATA, default .cache/cgal-data).
Writes into OUTDIR: one PNG per rendering step (Cycles, CPU), demo.blend and a
line appended to summary.md.

The demo is a list of steps (STEPS); each is a function taking the Demo
object.  A new capability adds a step: decorate a function with @step, run
its operator on demo.obj, and call demo.render("name.png", attribute).
"""

import argparse
import math
import sys
import time
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "addon"))
sys.path.insert(0, str(REPO / "blend_fixtures"))

import dgmesh  # noqa: E402
import make_fixtures  # noqa: E402

STEPS = []


def step(fn):
    """Register a demo step (they run in definition order)."""
    STEPS.append(fn)
    return fn


class Demo:
    def __init__(self, outdir, model, up="Y"):
        self.outdir = Path(outdir)
        self.model = model
        self.up = up  # the model's up axis
        self.obj = None
        self.parts = []  # summary fragments, in order

    @contextmanager
    def timed(self, label):
        t0 = time.perf_counter()
        yield
        self.parts.append(f"{label} {time.perf_counter() - t0:.2f} s")

    def note(self, text):
        self.parts.append(text)

    def render(self, filename, attribute):
        """Render the scene with demo.obj coloured by a colour attribute."""
        _show_color_attribute(self.obj, attribute)
        scene = bpy.context.scene
        scene.render.filepath = str(self.outdir / filename)
        with self.timed(f"render {filename}"):
            bpy.ops.render.render(write_still=True)


# --- steps ----------------------------------------------------------------------------------

@step
def load_model(demo):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with demo.timed(f"load {demo.model}"):
        obj = make_fixtures.load_cgal_object(demo.model)
    if demo.up == "Y":  # e.g. the Stanford bunny; Blender is z-up
        obj.rotation_euler = (math.radians(90), 0.0, 0.0)
    obj.data.polygons.foreach_set("use_smooth", np.ones(len(obj.data.polygons), dtype=bool))
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    demo.obj = obj
    demo.note(f"{len(obj.data.vertices)} vertices / {len(obj.data.polygons)} faces")
    _stage(obj)


@step
def curvature(demo):
    for kind in ('MEAN', 'GAUSSIAN'):
        with demo.timed(f"curvature_map {kind.lower()}"):
            result = bpy.ops.dgmesh.curvature_map(kind=kind)
        assert result == {'FINISHED'}, result
        demo.render(f"curvature_{kind.lower()}.png", "dg_curvature_color")


@step
def denoise(demo):
    """Similarity-based denoising (thesis ch. 2): Gaussian noise of 0.3 mean edge lengths along the
    normals, then dgmesh.denoise; both rendered by mean curvature. The model is restored after."""
    mesh = demo.obj.data
    n = len(mesh.vertices)
    co = np.empty(3 * n, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    nor = np.empty(3 * n, dtype=np.float32)
    mesh.vertices.foreach_get("normal", nor)
    edges = np.empty(2 * len(mesh.edges), dtype=np.int32)
    mesh.edges.foreach_get("vertices", edges)
    P = co.reshape(-1, 3).astype(np.float64)
    e = np.linalg.norm(P[edges[0::2]] - P[edges[1::2]], axis=1).mean()
    noise = np.random.default_rng(1).standard_normal(n)[:, None] * 0.3 * e
    noisy = P + noise * nor.reshape(-1, 3)
    mesh.vertices.foreach_set("co", noisy.astype(np.float32).ravel())
    mesh.update()
    assert bpy.ops.dgmesh.curvature_map(kind='MEAN') == {'FINISHED'}
    demo.render("denoise_noisy.png", "dg_curvature_color")
    with demo.timed("denoise (similarity, 3 iterations)"):
        result = bpy.ops.dgmesh.denoise()
    assert result == {'FINISHED'}, result
    assert bpy.ops.dgmesh.curvature_map(kind='MEAN') == {'FINISHED'}
    demo.render("denoise_similarity.png", "dg_curvature_color")
    mesh.vertices.foreach_set("co", co)
    mesh.update()
    assert bpy.ops.dgmesh.curvature_map(kind='MEAN') == {'FINISHED'}


@step
def crest_lines(demo):
    """Crest lines (thesis ch. 4) as a curve object: ridges blue, valleys red, on a grey model."""
    with demo.timed("crest_lines"):
        result = bpy.ops.dgmesh.crest_lines(threshold=10.0, create_curves=True)
    assert result == {'FINISHED'}, result
    curve = bpy.data.objects[f"{demo.obj.name} Crest Lines"]
    demo.note(f"{len(curve.data.splines)} crest lines")
    # Tubes thick enough to see at this size, with emissive colours (the operator only sets
    # viewport colours); the mesh gets a plain grey material for this render.
    radius = max(demo.obj.dimensions) / max(demo.obj.scale) * 0.0025
    curve.data.bevel_depth = radius
    curve.data.bevel_resolution = 1
    for mat in curve.data.materials:
        mat.use_nodes = True
        nodes = mat.node_tree.nodes
        nodes.clear()
        em = nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = mat.diffuse_color
        em.inputs["Strength"].default_value = 1.5
        out = nodes.new("ShaderNodeOutputMaterial")
        mat.node_tree.links.new(em.outputs["Emission"], out.inputs["Surface"])
    grey = _material("DG Grey", GREY)
    slots = demo.obj.material_slots
    previous = slots[0].material if len(slots) else None
    if len(slots):
        slots[0].material = grey
    else:
        demo.obj.data.materials.append(grey)
    scene = bpy.context.scene
    scene.render.filepath = str(demo.outdir / "crest_lines.png")
    with demo.timed("render crest_lines.png"):
        bpy.ops.render.render(write_still=True)
    if previous is not None:
        slots[0].material = previous
    curve.hide_render = True  # the later steps' renders are not about crest lines (it stays in the viewport)


@step
def unwrap(demo):
    """Low-stretch UV unwrap (thesis ch. 5) of a disk-like scan, checker material, render."""
    obj = make_fixtures.load_cgal_object("mannequin-devil")
    obj.data.polygons.foreach_set("use_smooth", np.ones(len(obj.data.polygons), dtype=bool))
    # Fit the scan into the main model's frame: same centre and size, seen by the same camera.
    main = demo.obj
    bpy.context.view_layer.update()
    size = max(main.dimensions) / max(max(obj.dimensions), 1e-9)
    obj.scale = (size, size, size)
    obj.rotation_euler = main.rotation_euler
    bpy.context.view_layer.update()
    centre = sum((main.matrix_world @ Vector(c) for c in main.bound_box), Vector()) / 8
    own = sum((obj.matrix_world @ Vector(c) for c in obj.bound_box), Vector()) / 8
    obj.location = obj.location + centre - own
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj
    with demo.timed("unwrap"):
        result = bpy.ops.dgmesh.unwrap()
    assert result == {'FINISHED'}, result
    assert bpy.ops.dgmesh.stretch_map(checker=True) == {'FINISHED'}
    mat = bpy.data.materials["DG Checker"]
    mat.node_tree.nodes["DG Checker"].inputs["Scale"].default_value = 24.0
    main.hide_render = True
    scene = bpy.context.scene
    scene.render.filepath = str(demo.outdir / "unwrap_checker.png")
    with demo.timed("render unwrap_checker.png"):
        bpy.ops.render.render(write_still=True)
    main.hide_render = False
    obj.hide_render = True
    bpy.context.view_layer.objects.active = main
    for o in bpy.context.view_layer.objects:
        o.select_set(o == main)
    demo.note(f"unwrapped {obj.name} ({len(obj.data.vertices)} vertices)")


@step
def skeletal(demo):
    """Skeleton-driven deformation (thesis ch. 6): a capsule bound to a two-bone armature, the lower
    bone bent 90 degrees and twisted 180; rendered next to Blender's Armature modifier (LBS)."""
    from dgmesh.skeletal import capsule
    V, F = capsule(0.5, 6.0, 48, 8, 96)
    me = bpy.data.meshes.new("DG Capsule")
    me.from_pydata([tuple(v) for v in V], [], [tuple(int(i) for i in f) for f in F])
    me.polygons.foreach_set("use_smooth", np.ones(len(me.polygons), dtype=bool))
    me.update()
    ad = bpy.data.armatures.new("DG Rig")
    arm = bpy.data.objects.new("DG Rig", ad)
    scene = bpy.context.scene
    bpy.context.view_layer.active_layer_collection.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    b1 = ad.edit_bones.new("Upper")
    b1.head, b1.tail = (-3.5, 0, 0), (0, 0, 0)
    b2 = ad.edit_bones.new("Lower")
    b2.head, b2.tail = (0, 0, 0), (3.5, 0, 0)
    b2.parent, b2.use_connect = b1, True
    bpy.ops.object.mode_set(mode='OBJECT')
    # Two copies of the capsule, side by side in the main model's frame: ours and the Armature
    # modifier, with the same linear-ramp vertex groups over [-0.5, 0.5].
    main = demo.obj
    bpy.context.view_layer.update()
    size = max(main.dimensions) / 10.0
    centre = sum((main.matrix_world @ Vector(c) for c in main.bound_box), Vector()) / 8
    t = np.clip(V[:, 0] + 0.5, 0, 1)
    objs = []
    for k, name in enumerate(("DG Capsule ours", "DG Capsule LBS")):
        obj = bpy.data.objects.new(name, me if k == 0 else me.copy())
        bpy.context.view_layer.active_layer_collection.collection.objects.link(obj)
        g1, g2 = obj.vertex_groups.new(name="Upper"), obj.vertex_groups.new(name="Lower")
        for i in range(len(V)):
            if t[i] < 1:
                g1.add([i], float(1 - t[i]), 'REPLACE')
            if t[i] > 0:
                g2.add([i], float(t[i]), 'REPLACE')
        mod = obj.modifiers.new("Armature", 'ARMATURE')
        mod.object = arm
        obj.scale = (size, size, size)
        obj.location = centre + Vector(((-2.5 if k == 0 else 2.5) * size, 0, -1.5 * size))
        objs.append(obj)
    arm.scale, arm.location = objs[0].scale, objs[0].location
    ours, lbs = objs
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (ours, arm))
    bpy.context.view_layer.objects.active = ours
    with demo.timed("skeletal_bind"):
        result = bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT')
    assert result == {'FINISHED'}, result
    # The LBS copy follows a second armature object with the same pose (its modifier stays on).
    arm2 = arm.copy()
    arm2.data = arm.data
    bpy.context.view_layer.active_layer_collection.collection.objects.link(arm2)
    arm2.location = lbs.location
    lbs.modifiers["Armature"].object = arm2
    for a in (arm, arm2):
        pb = a.pose.bones["Lower"]
        # Bone space: twist 180 degrees about the bone (Y) first, then bend 90 degrees upwards (X).
        pb.rotation_mode = 'YXZ'
        pb.rotation_euler = (math.pi / 2, math.pi, 0.0)
    with demo.timed("skeletal pose update"):
        scene.frame_set(scene.frame_current)
    main.hide_render = True
    for a in (arm, arm2):
        a.hide_render = True
    for o in bpy.data.objects:
        if o.name.endswith("_skeleton"):
            o.hide_render = True
    grey = _material("DG Grey", GREY)
    for o in objs:
        o.data.materials.clear()
        o.data.materials.append(grey)
    scene.render.filepath = str(demo.outdir / "skeletal_bend_twist.png")
    with demo.timed("render skeletal_bend_twist.png"):
        bpy.ops.render.render(write_still=True)
    main.hide_render = False
    for o in objs:
        o.hide_render = True
    bpy.context.view_layer.objects.active = main
    for o in bpy.context.view_layer.objects:
        o.select_set(o == main)
    demo.note(f"skeletal: {len(V)}-vertex capsule bent 90 and twisted 180 (left: ours, right: Armature modifier LBS)")


@step
def multires(demo):
    """Displaced subdivision (thesis 6.4): the model's decimated control mesh as a wireframe next to
    the model coloured by the displacement magnitude from the control mesh's Loop limit surface."""
    main = demo.obj
    _select_only(main)
    faces = max(500, min(5000, len(main.data.polygons) // 20))
    with demo.timed("multires_preview"):
        result = bpy.ops.dgmesh.multires_preview('EXEC_DEFAULT', control_faces=faces)
    assert result == {'FINISHED'}, result
    ctrl = next(o for o in bpy.data.objects if o.get("dgmesh_multires_control_of") == main)
    mag = np.empty(len(main.data.vertices), dtype=np.float32)
    main.data.attributes["dg_multires_magnitude"].data.foreach_get("value", mag)
    co = np.empty(3 * len(main.data.vertices), dtype=np.float32)
    main.data.vertices.foreach_get("co", co)
    P = co.reshape(-1, 3)
    diag = float(np.linalg.norm(P.max(0) - P.min(0)))
    # The control mesh as tubes, next to the model.
    ctrl.data.materials.clear()
    ctrl.data.materials.append(_material("DG Wire", DARK))
    _wireframe(ctrl, 0.002 * diag, replace=True)
    with _side_by_side(demo, (main, ctrl)):
        demo.render("multires_control_displacement.png", "dg_multires_color")
    ctrl.hide_render = True
    demo.note(f"multires: {len(P)} vertices on a {len(ctrl.data.polygons)}-face control mesh, "
              f"|displacement| RMS {float(np.sqrt((mag.astype(np.float64) ** 2).mean())) / diag:.1e} "
              f"max {float(mag.max()) / diag:.1e} of the diagonal")


def _crest_copies(demo, names):
    """Copies of the demo model (own mesh data) for side-by-side renders; the model is hidden."""
    main = demo.obj
    copies = []
    for name in names:
        obj = main.copy()
        obj.data = main.data.copy()
        obj.name = obj.data.name = f"{main.name} {name}"
        for coll in main.users_collection:
            coll.objects.link(obj)
        copies.append(obj)
    return copies


def _select_only(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj


GREY = (0.75, 0.75, 0.72, 1.0)
DARK = (0.05, 0.05, 0.08, 1.0)


def _material(name, rgba):
    """A plain material of one colour (viewport and Principled BSDF), reused by name."""
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.diffuse_color = rgba
    mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = rgba
    return mat


def _wireframe(obj, thickness, replace):
    """Edges as tubes in the object's second material slot (the wire display type does not render)."""
    wire = obj.modifiers.new("DG Wire", 'WIREFRAME')
    wire.thickness = thickness
    wire.use_replace = replace
    wire.material_offset = 0 if replace else 1


@contextmanager
def _side_by_side(demo, pair):
    """The two objects moved apart along the camera's right axis, the view widened to fit both."""
    cam = bpy.context.scene.camera
    offset = cam.matrix_world.to_3x3().col[0].normalized() * (0.55 * max(demo.obj.dimensions))
    saved = [o.location.copy() for o in pair], cam.data.lens
    pair[0].location = saved[0][0] - offset
    pair[1].location = saved[0][1] + offset
    cam.data.lens = saved[1] * 0.5
    try:
        yield
    finally:
        for o, loc in zip(pair, saved[0]):
            o.location = loc
        cam.data.lens = saved[1]


def _render_pair(demo, pair, filename):
    """Render the two objects side by side (the model hidden); both are hidden from renders after."""
    main = demo.obj
    main.hide_render = True
    with _side_by_side(demo, pair):
        scene = bpy.context.scene
        scene.render.filepath = str(demo.outdir / filename)
        with demo.timed(f"render {filename}"):
            bpy.ops.render.render(write_still=True)
    main.hide_render = False
    for o in pair:
        o.hide_render = True


def _near_crest_fraction(obj, points, radius):
    """Fraction of the object's vertices within `radius` of a crest-line point."""
    co = np.empty(3 * len(obj.data.vertices), dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    P = co.reshape(-1, 3).astype(np.float64)
    near = np.zeros(len(P), bool)
    for i in range(0, len(P), 2048):
        d2 = ((P[i:i + 2048, None, :] - points[None, :, :]) ** 2).sum(2)
        near[i:i + 2048] = d2.min(1) <= radius * radius
    return float(near.mean())


@step
def decimate(demo):
    """Feature-sensitive decimation (thesis 4.8, fig. 4.19): the model decimated by 90% with plain
    quadrics (eta = 0, left) and weighted by the distance to crest lines (eta = 6, right), as
    wireframes on grey."""
    plain, weighted = _crest_copies(demo, ("QEM", "Feature QEM"))
    n = sum(len(p.vertices) - 2 for p in demo.obj.data.polygons)
    grey, dark = _material("DG Grey", GREY), _material("DG Wire", DARK)
    from dgmesh.blender import bridge
    arrays = bridge.read_object(demo.obj)
    diag = float(np.linalg.norm(arrays.V.max(0) - arrays.V.min(0)))
    lines = dgmesh.crest_lines(arrays.V, arrays.F, rings=1, threshold=10.0)
    fractions = []
    for obj, eta in ((plain, 0.0), (weighted, 6.0)):
        _select_only(obj)
        with demo.timed(f"decimate_features eta {eta:g}"):
            result = bpy.ops.dgmesh.decimate_features(ratio=0.1, feature_weight=eta, rings=1, threshold=10.0)
        assert result == {'FINISHED'}, result
        obj.data.materials.clear()
        obj.data.materials.append(grey)
        obj.data.materials.append(dark)
        _wireframe(obj, 0.0008 * diag, replace=False)
        fractions.append(_near_crest_fraction(obj, lines.points, 0.01 * diag))
    _render_pair(demo, (plain, weighted), "decimate_eta0_eta6.png")
    demo.note(f"decimate 90%: {n} -> {len(plain.data.polygons)} / {len(weighted.data.polygons)} triangles "
              f"(eta 0 / 6, {len(lines)} crest lines T >= 10); vertices within 1% of the diagonal from a "
              f"crest line: {100 * fractions[0]:.0f}% / {100 * fractions[1]:.0f}%")
    _select_only(demo.obj)


@step
def segment(demo):
    """Feature-guided segmentation (thesis 4.9, fig. 4.26): 25 segments by VSA (eta = 0, left) and
    guided by crest lines (eta = 2, right), a colour per segment, borders marked as seams."""
    plain, guided = _crest_copies(demo, ("VSA", "Feature VSA"))
    borders = []
    for obj, eta in ((plain, 0.0), (guided, 2.0)):
        _select_only(obj)
        with demo.timed(f"segment eta {eta:g}"):
            result = bpy.ops.dgmesh.segment(segments=25, feature_weight=eta, rings=1, threshold=10.0,
                                            mark_seams=True)
        assert result == {'FINISHED'}, result
        labels = np.empty(len(obj.data.polygons), dtype=np.int32)
        obj.data.attributes["dg_segment"].data.foreach_get("value", labels)
        seams = np.empty(len(obj.data.edges), dtype=bool)
        obj.data.edges.foreach_get("use_seam", seams)
        borders.append((int(labels.max()) + 1, int(seams.sum())))
        obj.data.materials.clear()
        _show_color_attribute(obj, "dg_segment_color")
    _render_pair(demo, (plain, guided), "segment_eta0_eta2.png")
    demo.note(f"segment: {borders[0][0]} / {borders[1][0]} segments (eta 0 / 2), "
              f"{borders[0][1]} / {borders[1][1]} seam edges on their borders")
    _select_only(demo.obj)


@step
def remesh(demo):
    """Remeshing by double parameterization (thesis 5.4): the lion-head disk scan (left) and its
    remesh to 3000 vertices (right, sampled on Uopt, Delaunay on U0, density half curvature-adapted),
    both with their wireframe."""
    main = demo.obj
    src = make_fixtures.load_cgal_object("lion-head")
    bpy.context.view_layer.update()
    size = max(main.dimensions) / max(max(src.dimensions), 1e-9)
    src.scale = (size, size, size)
    src.rotation_euler = main.rotation_euler
    bpy.context.view_layer.update()
    centre = sum((main.matrix_world @ Vector(c) for c in main.bound_box), Vector()) / 8
    own = sum((src.matrix_world @ Vector(c) for c in src.bound_box), Vector()) / 8
    src.location = src.location + centre - own
    new = src.copy()
    new.data = src.data.copy()
    new.name = src.name + " remeshed"
    bpy.context.scene.collection.objects.link(new)
    _select_only(new)
    with demo.timed("remesh"):
        result = bpy.ops.dgmesh.remesh('EXEC_DEFAULT', target_vertices=3000, resolution=512, mode='DOUBLE',
                                       adaptivity=0.5)
    assert result == {'FINISHED'}, result
    grey, dark = _material("DG Grey", GREY), _material("DG Wire", DARK)
    for o in (src, new):
        o.data.materials.clear()
        o.data.materials.append(grey)
        o.data.materials.append(dark)
        o.data.polygons.foreach_set("use_smooth", np.zeros(len(o.data.polygons), dtype=bool))
        _wireframe(o, 0.0015 * max(src.dimensions), replace=False)
    _render_pair(demo, (src, new), "remesh_wireframe.png")
    for o in (src, new):
        o.hide_viewport = True
    _select_only(main)
    demo.note(f"remeshed lion-head {len(src.data.vertices)} -> {len(new.data.vertices)} vertices")


@step
def fair(demo):
    """Hole restoration (thesis fig. 3.6-3.7) as a user does it, on a copy of the model: delete a
    geodesic disk of 5% of the area facing the camera, fill the hole (F: one n-gon), keep the fill
    selected, run dgmesh.fair with Refine Fill (Liepa-style refinement to the rim's edge lengths, then the
    Willmore flow); the filled and the faired copy rendered by mean curvature."""
    import bmesh
    sys.path.insert(0, str(REPO))
    from bench.workloads.fair import cut_hole

    src = demo.obj
    obj = src.copy()
    obj.data = src.data.copy()
    obj.name = obj.data.name = "Fair"
    bpy.context.scene.collection.objects.link(obj)
    src.hide_render = True
    n = len(obj.data.vertices)
    co = np.empty(3 * n, dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    nor = np.empty(3 * n, dtype=np.float32)
    obj.data.vertices.foreach_get("normal", nor)
    V = co.reshape(-1, 3).astype(np.float64)
    F = np.array([p.vertices[:] for p in obj.data.polygons if len(p.vertices) == 3], dtype=np.int32)
    # Centre: among the vertices facing the camera most, the first whose disk is a clean hole.
    M = np.array(obj.matrix_world)[:3, :3]
    cam = bpy.context.scene.camera
    view = (np.array(cam.location) - (V @ M.T))
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    facing = ((nor.reshape(-1, 3) @ M.T) * view).sum(1)
    got = None
    for c in np.argsort(-facing)[:400:10]:
        got = cut_hole(V, F, int(c), 0.05)
        if got is None:
            continue
        # Skip rims with a chord (an outside edge joining two rim vertices): Fill would reuse it.
        on_rim = np.zeros(n, bool)
        on_rim[F[got[0]].ravel()] = True
        on_rim &= ~got[1]
        Fk = F[~got[0]]
        E = np.sort(np.concatenate([Fk[:, [0, 1]], Fk[:, [1, 2]], Fk[:, [2, 0]]]), axis=1)
        E = np.unique(E[on_rim[E].all(1)], axis=0)
        if len(E) == on_rim.sum():  # only the rim loop's own edges
            break
        got = None
    assert got is not None, "no disk-shaped hole found"
    hole, inner = got
    rim = np.unique(F[hole])
    rim = rim[~inner[rim]]

    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode='EDIT')
    bm = bmesh.from_edit_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    rim_verts = {bm.verts[int(i)] for i in rim}
    bmesh.ops.delete(bm, geom=[bm.verts[int(i)] for i in np.flatnonzero(inner)], context='VERTS')
    for f in bm.faces:
        f.select = False
    for e in bm.edges:
        e.select = False
    for v in bm.verts:
        v.select = False
    for e in bm.edges:
        if e.is_boundary and e.verts[0] in rim_verts and e.verts[1] in rim_verts:
            e.select = True
            e.verts[0].select = e.verts[1].select = True
    bmesh.update_edit_mesh(obj.data)
    assert bpy.ops.mesh.edge_face_add() == {'FINISHED'}  # F: one n-gon, selected
    bpy.ops.mesh.normals_make_consistent(inside=False)
    bpy.ops.object.mode_set(mode='OBJECT')
    filled = sum(p.select for p in obj.data.polygons)
    demo.obj = obj
    assert bpy.ops.dgmesh.curvature_map(kind='MEAN') == {'FINISHED'}
    demo.render("fair_filled.png", "dg_curvature_color")
    bpy.ops.object.mode_set(mode='EDIT')
    with demo.timed(f"fair ({int(inner.sum())} vertices removed, {filled} fill n-gon, Refine Fill)"):
        result = bpy.ops.dgmesh.fair(refine=True, subdivisions=0)
    assert result == {'FINISHED'}, result
    bpy.ops.object.mode_set(mode='OBJECT')
    assert bpy.ops.dgmesh.curvature_map(kind='MEAN') == {'FINISHED'}
    demo.render("fair_restored.png", "dg_curvature_color")
    demo.note(f"fair: hole patch of {len(obj.data.vertices) - (n - int(inner.sum()))} new vertices")
    obj.hide_render = True
    src.hide_render = False
    demo.obj = src


@step
def save(demo):
    path = demo.outdir / "demo.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    demo.note(f"saved {path.name}")


# --- scene helpers --------------------------------------------------------------------------

def _stage(obj):
    """Camera, light, world and Cycles settings framing ``obj``."""
    scene = bpy.context.scene
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    radius = (corners[6] - corners[0]).length / 2

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 50
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    direction = Vector((0.55, -1.0, 0.35)).normalized()  # front-right, slightly above
    cam.rotation_euler = (-direction).to_track_quat('-Z', 'Y').to_euler()
    # Fit the view to the vertices (tighter than the bounding box), then back
    # off a little for a margin.
    co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    M = np.array(obj.matrix_world)
    world = co.reshape(-1, 3) @ M[:3, :3].T + M[:3, 3]
    location, _scale = cam.camera_fit_coords(bpy.context.evaluated_depsgraph_get(), world.ravel().tolist())
    cam.location = location + direction * (0.25 * radius)

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", 'SUN'))
    sun.data.energy = 2.0
    sun.data.angle = math.radians(10)
    sun.rotation_euler = Vector((0.3, -0.6, 1.0)).to_track_quat('Z', 'Y').to_euler()
    scene.collection.objects.link(sun)

    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.4
    scene.world = world

    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False  # this Blender build has no OpenImageDenoise
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    scene.view_settings.view_transform = 'Standard'  # show the palette's colours, not Filmic's


def _show_color_attribute(obj, attribute):
    """Give ``obj`` a material whose base colour is the named colour attribute."""
    mat = bpy.data.materials.get("DG Attribute") or bpy.data.materials.new("DG Attribute")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes.get("Principled BSDF")
    attr = nodes.get("DG Color") or nodes.new("ShaderNodeAttribute")
    attr.name = "DG Color"
    attr.attribute_type = 'GEOMETRY'
    attr.attribute_name = attribute
    attr.location = (-300, 200)
    links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.6
    # "Specular" was renamed in 4.0; a dim highlight keeps the colours readable.
    spec = bsdf.inputs.get("Specular") or bsdf.inputs.get("Specular IOR Level")
    if spec is not None:
        spec.default_value = 0.2
    if not obj.data.materials:
        obj.data.materials.append(mat)


# --- main -----------------------------------------------------------------------------------

def main(argv):
    parser = argparse.ArgumentParser(prog="demo.py")
    parser.add_argument("outdir")
    parser.add_argument("--model", default="bunny00", help="CGAL data mesh name")
    parser.add_argument("--up", choices=("Y", "Z"), default="Y", help="the model's up axis")
    parser.add_argument("--steps", help="comma-separated subset of: " + ", ".join(s.__name__ for s in STEPS))
    args = parser.parse_args(argv)
    wanted = args.steps.split(",") if args.steps else [s.__name__ for s in STEPS]
    unknown = set(wanted) - {s.__name__ for s in STEPS}
    if unknown:
        parser.error(f"unknown steps: {', '.join(sorted(unknown))}")

    dgmesh.register()
    demo = Demo(args.outdir, args.model, args.up)
    demo.outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    for fn in STEPS:
        if fn.__name__ in wanted:
            print(f"demo: {fn.__name__}", flush=True)
            fn(demo)
    line = (f"- {datetime.now():%Y-%m-%d %H:%M} demo.py (Blender {bpy.app.version_string}, "
            f"dgmesh {dgmesh.__version__}, {dgmesh.num_threads()} threads) {demo.model}: "
            + "; ".join(demo.parts) + f"; total {time.perf_counter() - t0:.1f} s\n")
    with open(demo.outdir / "summary.md", "a") as fh:
        fh.write(line)
    print(line, end="")


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
