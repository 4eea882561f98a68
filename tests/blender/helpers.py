"""Helpers shared by the Blender tests (import as ``helpers``)."""

import sys
from pathlib import Path

import bpy
import numpy as np

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "blend_fixtures"
sys.path.insert(0, str(FIXTURES))
import make_fixtures  # noqa: E402,F401  (needs the path above; re-exported to the tests)

DG_ATTRIBUTES = ("dg_mean_curvature", "dg_gaussian_curvature", "dg_curvature_color")


def open_fixture(name):
    """Open blend_fixtures/<name>.blend (keeps the current UI and add-ons)."""
    bpy.ops.wm.open_mainfile(filepath=str(FIXTURES / f"{name}.blend"), load_ui=False)
    assert bpy.context.mode == 'OBJECT'


def select(*names, active=None):
    """Select exactly the named objects; the active one is ``active`` or the first."""
    names = set(names)
    bpy.context.view_layer.update()  # bases of objects just made local or overridden
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj.name in names)
    active = active or (sorted(names)[0] if names else None)
    bpy.context.view_layer.objects.active = bpy.data.objects[active] if active else None


def curvature_map(**props):
    """Run the operator the way the UI does: with an undo push."""
    return bpy.ops.dgmesh.curvature_map('EXEC_DEFAULT', True, **props)


def independent_arrays(mesh):
    """(V, F) read with plain Python (not through the bridge), to cross-check it."""
    mesh.calc_loop_triangles()
    V = np.array([v.co[:] for v in mesh.vertices], dtype=np.float64).reshape(-1, 3)
    F = np.array([t.vertices[:] for t in mesh.loop_triangles], dtype=np.int32).reshape(-1, 3)
    return V, F


def attribute_array(attr):
    """The data of a generic attribute as a numpy array (any type/domain)."""
    key, width, dtype = _ATTR_LAYOUT.get(attr.data_type, (None, None, None))
    n = len(attr.data)
    if key is None:  # types without a fast path (e.g. STRING): compare their Python values
        return np.array([repr(tuple(d.bl_rna.properties.keys())) + repr(getattr(d, "value", None))
                         for d in attr.data], dtype=object)
    buf = np.empty(n * width, dtype=dtype)
    attr.data.foreach_get(key, buf)
    return buf.reshape(n, width)


_ATTR_LAYOUT = {
    'FLOAT': ("value", 1, np.float32),
    'INT': ("value", 1, np.int32),
    'INT8': ("value", 1, np.int32),
    'BOOLEAN': ("value", 1, bool),
    'FLOAT_VECTOR': ("vector", 3, np.float32),
    'FLOAT2': ("vector", 2, np.float32),
    'FLOAT_COLOR': ("color", 4, np.float32),
    'BYTE_COLOR': ("color", 4, np.float32),
    'INT32_2D': ("value", 2, np.int32),  # 4.x
    'QUATERNION': ("value", 4, np.float32),  # 4.x
    'INT16_2D': ("value", 2, np.int32),  # 5.x: custom_normal
}


def _get(collection, key, width, dtype):
    buf = np.empty(len(collection) * width, dtype=dtype)
    collection.foreach_get(key, buf)
    return buf.tobytes()


def layer_uv(mesh, name=None):
    """(loops, 2) UVs of the named or the active UV map."""
    layer = mesh.uv_layers[name] if name else mesh.uv_layers.active
    uv = np.empty(2 * len(mesh.loops), np.float32)
    layer.data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)


def mesh_snapshot(mesh):
    """Everything a mesh stores, as comparable values (bytes for arrays, so
    NaN compares equal to itself)."""
    snap = {
        "co": _get(mesh.vertices, "co", 3, np.float32),
        "edges": _get(mesh.edges, "vertices", 2, np.int32),
        "loop_start": _get(mesh.polygons, "loop_start", 1, np.int32),
        "loop_total": _get(mesh.polygons, "loop_total", 1, np.int32),
        "loop_vertex": _get(mesh.loops, "vertex_index", 1, np.int32),
        "loop_edge": _get(mesh.loops, "edge_index", 1, np.int32),
        "use_smooth": _get(mesh.polygons, "use_smooth", 1, bool),
        "vertex_select": _get(mesh.vertices, "select", 1, bool),
        "attributes": {
            a.name: (a.domain, a.data_type, attribute_array(a).tobytes())
            for a in mesh.attributes
        },
        "active_color": (mesh.color_attributes.active_color.name
                         if mesh.color_attributes.active_color else None),
        "render_color_index": mesh.color_attributes.render_color_index,
        "uv_layers": {
            uv.name: _get(uv.data, "uv", 2, np.float32) for uv in mesh.uv_layers
        },
        "uv_active": mesh.uv_layers.active.name if mesh.uv_layers.active else None,
        # Vertex group weights live on the mesh (plain loop: fixtures are small).
        "weights": [(v.index, g.group, round(g.weight, 6)) for v in mesh.vertices for g in v.groups],
        "has_custom_normals": mesh.has_custom_normals,
        "shape_keys": None,
    }
    if mesh.shape_keys is not None:
        snap["shape_keys"] = {
            kb.name: (kb.value, kb.relative_key.name, _get(kb.data, "co", 3, np.float32))
            for kb in mesh.shape_keys.key_blocks
        }
    if mesh.has_custom_normals:
        if hasattr(mesh, "calc_normals_split"):  # 3.x/4.0; 4.1+ computes corner normals on access
            mesh.calc_normals_split()
        snap["corner_normals"] = np.round(
            np.frombuffer(_get(mesh.loops, "normal", 3, np.float32), np.float32), 5).tobytes()
    return snap


def without_dg(snapshot):
    """A snapshot with the operator's own outputs removed."""
    snap = dict(snapshot)
    snap["attributes"] = {k: v for k, v in snapshot["attributes"].items() if k not in DG_ATTRIBUTES}
    for key in ("active_color", "render_color_index"):
        snap.pop(key)
    return snap


def keep_mirror_half(obj):
    """Deletes the x < 0 half and adds a Mirror modifier (X, Merge on), as a user models a half."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.delete(bm, geom=[v for v in bm.verts if v.co.x < -1e-6], context='VERTS')
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    obj.modifiers.new("Mirror", 'MIRROR')


def link_and_override(lib, collection):
    """Links ``collection`` from the .blend ``lib`` and makes it a library override, as Make Library
    Override does on a linked collection instance (its operator's poll needs a window in 4.x):
    returns the overridden collection, linked into the scene."""
    with bpy.data.libraries.load(str(lib), link=True) as (_src, dst):
        dst.collections = [collection]
    linked = dst.collections[0]
    inst = bpy.data.objects.new(collection + " Instance", None)
    inst.instance_type, inst.instance_collection = 'COLLECTION', linked
    bpy.context.scene.collection.objects.link(inst)
    over = linked.override_hierarchy_create(bpy.context.scene, bpy.context.view_layer, reference=inst)
    bpy.data.objects.remove(inst)
    return over


# Start of every windowed script: the add-on enabled, `state` and `out` dicts, invoke(), and
# invoke_to_cancel() with esc_until_worker_ends() for a run cancelled by Esc.
WINDOWED_PRELUDE = r"""
import sys, threading, time
sys.path.insert(0, sys.argv[sys.argv.index("--") + 1])
import bpy
import run as runner
runner.enable_addon()
state = {"phase": 0}
out = {}

def invoke(opname, **props):
    # bpy.ops.dgmesh.<opname> invoked over the first 3D view, as a click there would.
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    region = next(r for r in area.regions if r.type == 'WINDOW')
    with bpy.context.temp_override(window=win, area=area, region=region):
        return getattr(bpy.ops.dgmesh, opname)('INVOKE_DEFAULT', **props)

def invoke_to_cancel(opname, **props):
    # Invokes a run to be cancelled: notes the threads before it and the start for esc_until_worker_ends.
    state["threads"] = threading.active_count()
    result = sorted(invoke(opname, **props))
    state["t0"], state["esc"] = time.time(), 0
    return result

def esc_until_worker_ends():
    # Presses Esc while the run's worker thread lives; True once it ended (or after 120 s).
    win = bpy.context.window_manager.windows[0]
    if threading.active_count() > state["threads"] and state["esc"] < 10:
        win.event_simulate(type='ESC', value='PRESS')
        win.event_simulate(type='ESC', value='RELEASE')
        state["esc"] += 1
        return False
    if threading.active_count() <= state["threads"]:
        out["worker_seconds"] = round(time.time() - state["t0"], 2)
        return True
    return time.time() - state["t0"] > 120

def report_and_quit():
    print("MODAL_RESULT", out, flush=True)
    bpy.ops.wm.quit_blender()
"""


def run_windowed(tmp_path, script_text, timeout=240):
    """Runs WINDOWED_PRELUDE + ``script_text`` (which defines step(), a timer callback) in a
    windowed Blender under Xvfb with event simulation (invoke, modal operators and Esc need a
    window; the test session has none) and returns the dict report_and_quit() prints."""
    import subprocess

    script = tmp_path / "windowed.py"
    script.write_text(WINDOWED_PRELUDE + script_text + "\nbpy.app.timers.register(step, first_interval=1.0)\n")
    tests_dir = Path(__file__).resolve().parent
    proc = subprocess.run(["xvfb-run", "-a", bpy.app.binary_path, "--factory-startup", "--enable-event-simulate",
                           "--python", str(script), "--", str(tests_dir)],
                          capture_output=True, text=True, timeout=timeout)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("MODAL_RESULT")), None)
    assert line is not None, proc.stdout[-2000:] + proc.stderr[-2000:]
    return eval(line[len("MODAL_RESULT"):])


def add_mesh_object(name, V, F):
    """A mesh object `name` from vertices V and triangles F, linked to the scene."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(v) for v in V], [], [tuple(int(i) for i in f) for f in F])
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_armature(bones, name="Rig"):
    """An armature object `name` linked to the scene (and left active, in Object mode) with
    `bones`: (name, head, tail, parent name or None, connected to it), parents first."""
    ad = bpy.data.armatures.new(name)
    arm = bpy.data.objects.new(name, ad)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode='EDIT')
    for bone, head, tail, parent, connect in bones:
        b = ad.edit_bones.new(bone)
        b.head, b.tail = head, tail
        if parent:
            b.parent = ad.edit_bones[parent]
            b.use_connect = connect
    bpy.ops.object.mode_set(mode='OBJECT')
    return arm
