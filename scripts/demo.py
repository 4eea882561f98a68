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
    demo.note(f"unwrapped {obj.name} ({len(obj.data.vertices)} vertices)")@step
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
