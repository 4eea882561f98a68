"""Smoke test of the INSTALLED portable add-on, run inside Blender by scripts/package_test.sh:

    blender --background --python-exit-code 1 --python tests/package/smoke_blender.py -- \
        --module MODULE [--install-legacy ZIP] --root INSTALL_ROOT

--install-legacy installs ZIP the way Preferences > Add-ons > Install does (addon_install), into
the user scripts folder of this run (BLENDER_USER_SCRIPTS, a fresh temporary folder); without it
the add-on is expected to be installed already (an extension, `blender --command extension
install-file`). Then it enables MODULE, checks that it and its compiled module were loaded from
INSTALL_ROOT (not from the source tree) and runs one operator of each capability on a small mesh.
Any failure raises, so Blender exits with code 1.
"""
import argparse
import importlib
import os
import sys

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--module", required=True)
ap.add_argument("--install-legacy")
ap.add_argument("--root", required=True)
args = ap.parse_args(argv)
root = os.path.realpath(args.root)

print(f"smoke: Blender {bpy.app.version_string}, Python {sys.version.split()[0]}")
if args.install_legacy:
    assert bpy.ops.preferences.addon_install(filepath=args.install_legacy) == {'FINISHED'}
    addon_utils.modules_refresh()
mod = addon_utils.enable(args.module, default_set=True, handle_error=None)
assert mod is not None, f"enabling {args.module} failed"
pkg = importlib.import_module(args.module)
native = importlib.import_module(args.module + "._native")
for m in (pkg, native):
    path = os.path.realpath(m.__file__)
    print(f"smoke: {m.__name__} from {path}")
    assert path.startswith(root + os.sep), f"{m.__name__} was not loaded from the installed copy {root}"
import numpy  # noqa: E402
print(f"smoke: numpy {numpy.__version__}, module {os.path.basename(native.__file__)}")
# A native error must come through as the package's MeshError (an exception thrown in the C++
# library and caught by the module's bindings).
try:
    pkg.validate(numpy.zeros((0, 3)), numpy.zeros((0, 3), numpy.int32))
    raise AssertionError("validate accepted an empty mesh")
except pkg.MeshError as e:
    print(f"smoke: native MeshError comes through: {e}")
shapes = importlib.import_module(args.module + ".shapes")
skeletal = importlib.import_module(args.module + ".skeletal")


def _fail(msg):
    raise AssertionError(msg)


def new_object(name, V, F):
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in V], [], [tuple(map(int, f)) for f in F])
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()  # the view layer lists the object only after an update
    return obj


def only(*objs, active=None):
    for o in bpy.context.view_layer.objects:
        o.select_set(o in objs)
    bpy.context.view_layer.objects.active = active or objs[0]


def coords(obj):
    out = numpy.empty(3 * len(obj.data.vertices))
    obj.data.vertices.foreach_get("co", out)
    return out


failed = []


def run(op, check=None, **props):
    """Runs dgmesh.OP and CHECK(); a failure is recorded (and printed) and the next one runs."""
    try:
        res = getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **props)
        assert res == {'FINISHED'}, res
        if check:
            check()
        print(f"smoke: dgmesh.{op}: ok")
    except Exception as e:  # noqa: BLE001  (every failure is reported at the end)
        import traceback
        traceback.print_exc()
        print(f"smoke: dgmesh.{op}: FAILED: {e!r}")
        failed.append(op)


def assert_moved(obj, before, what):
    assert not numpy.allclose(before, coords(obj)), f"{what} changed nothing"


bpy.ops.wm.read_homefile(use_empty=True)
V, F = shapes.icosphere(3)
rng = numpy.random.default_rng(1)
sphere = new_object("Sphere", V + 0.01 * rng.standard_normal(V.shape), F)
only(sphere)
run("curvature_map", lambda: ("dg_mean_curvature" in sphere.data.attributes) or _fail("no attribute"))
before = coords(sphere)
run("denoise", lambda: assert_moved(sphere, before, "denoise"))
before2 = coords(sphere)
run("fair", lambda: assert_moved(sphere, before2, "fair"))
run("crest_lines", threshold=0.0)

# A bumpy open grid (a disk): Unwrap and Remesh need a boundary.
n = 16
x, y = numpy.meshgrid(numpy.linspace(-1, 1, n), numpy.linspace(-1, 1, n))
G = numpy.c_[x.ravel(), y.ravel(), 0.2 * numpy.sin(3 * x.ravel()) * numpy.cos(2 * y.ravel())]
Fg = [(i * n + j, i * n + j + 1, (i + 1) * n + j + 1, (i + 1) * n + j) for i in range(n - 1) for j in range(n - 1)]
grid = new_object("Grid", G, Fg)
only(grid)
run("unwrap", lambda: len(grid.data.uv_layers) > 0 or _fail("no UV map"))
only(grid)
run("remesh", lambda: len(grid.data.vertices) != n * n or _fail("remesh kept the vertex count"),
    target_vertices=150, resolution=128)

# Skeletal Bind: a capsule with a two-bone armature and vertex groups, as tests/blender do.
Vc, Fc = skeletal.capsule(0.5, 6.0, 24, 5, 32)
cap = new_object("Capsule", Vc, Fc)
ad = bpy.data.armatures.new("Rig")
arm = bpy.data.objects.new("Rig", ad)
bpy.context.scene.collection.objects.link(arm)
bpy.context.view_layer.update()
only(arm)
bpy.ops.object.mode_set(mode='EDIT')
b1 = ad.edit_bones.new("Upper")
b1.head, b1.tail = (-3.5, 0, 0), (0, 0, 0)
b2 = ad.edit_bones.new("Lower")
b2.head, b2.tail = (0, 0, 0), (3.5, 0, 0)
b2.parent, b2.use_connect = b1, True
bpy.ops.object.mode_set(mode='OBJECT')
g1, g2 = cap.vertex_groups.new(name="Upper"), cap.vertex_groups.new(name="Lower")
t = numpy.clip(Vc[:, 0] + 0.5, 0, 1)
for i in range(len(Vc)):
    if t[i] < 1:
        g1.add([i], float(1 - t[i]), 'REPLACE')
    if t[i] > 0:
        g2.add([i], float(t[i]), 'REPLACE')
cap.modifiers.new("Armature", 'ARMATURE').object = arm
only(cap, arm, active=cap)
run("skeletal_bind")
if failed:
    raise SystemExit(f"smoke: FAILED in Blender {bpy.app.version_string}: {', '.join(failed)}")
print("smoke: all operators ran from the installed add-on")
