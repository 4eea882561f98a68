"""Operators dgmesh.skeletal_bind / skeletal_unbind / skeletal_bake (thesis chapter 6).

Bind (a mesh and an armature selected, the mesh active): the mesh is bound to the armature's
deform bones with the weights of its vertex groups named after them (distance-based Gaussian
weights when it has none). The bind data is stored in the .blend (a custom property of the mesh
object holding the compressed arrays), plus a hidden object ``<mesh>_skeleton`` showing the
skeletal mesh coloured by its medial-ball radius (thesis fig. 6.8). The basis is never changed:
the deformed positions go to the shape key ``dg_skeletal`` (value 1), refreshed by a depsgraph /
frame-change handler whenever the pose changes (Pose mode, timeline, renders, ``frame_set`` in
--background). The mesh's own Armature modifiers are disabled while bound and restored on unbind.

Bake writes a frame range to a .pc2 point cache played by a Mesh Cache modifier, so renders and
exports need no add-on. Unbind removes everything bind added and leaves the mesh as it was.
"""

import base64
import io
import struct
import uuid

import bpy
import numpy as np
from bpy.props import EnumProperty, IntProperty, StringProperty

from .. import colors
from ..core import MeshError
from ..skeletal import SkeletalRig
from . import bridge
from .common import poll_fail as _poll_fail

PROP = "dg_skeletal"            # custom property (dict) on the mesh object
KEY = "dg_skeletal"             # shape key name
METHODS = (
    ('VARIATIONAL', "Variational", "Thesis 6.5: stitched per-triangle frames plus shape-preserving fairing"),
    ('BASIC', "Basic", "Thesis 6.3: homotopy reconstruction with fold and self-intersection fairing (comparison)"),
)

_rigs = {}          # bind id -> SkeletalRig (rebuilt from the stored data after a reload)
_last_pose = {}     # bind id -> bytes of the last pose matrices
_updating = False   # re-entrancy guard: writing the shape key triggers another depsgraph update


def _armature_of(context, mesh_obj):
    for o in context.selected_objects:
        if o.type == 'ARMATURE' and o is not mesh_obj:
            return o
    for m in mesh_obj.modifiers:
        if m.type == 'ARMATURE' and m.object is not None:
            return m.object
    return None


def _pose_matrices(mesh_obj, arm, names, rest=False):
    to_mesh = mesh_obj.matrix_world.inverted() @ arm.matrix_world
    out = np.empty((len(names), 4, 4))
    for j, name in enumerate(names):
        m = arm.data.bones[name].matrix_local if rest else arm.pose.bones[name].matrix
        out[j] = np.array(to_mesh @ m)
    return out


def _encode(arrays):
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _decode(text):
    with np.load(io.BytesIO(base64.b64decode(text))) as z:
        return {k: z[k] for k in z.files}


def is_bound(obj):
    return obj is not None and obj.type == 'MESH' and PROP in obj.keys()


def _rig(obj):
    info = obj[PROP]
    bid = info["id"]
    rig = _rigs.get(bid)
    if rig is None:
        rig = SkeletalRig.from_arrays(_decode(info["data"]))
        _rigs[bid] = rig
    return rig


_buffers = {}  # bind id -> (float64 (n, 3), float32 (n*3,)) reused by every live update


def _deformed(obj, pose):
    info = obj[PROP]
    rig = _rig(obj)
    buf = _buffers.get(info["id"])
    if buf is None or buf[0].shape[0] != rig.n_vertices:
        buf = (np.empty((rig.n_vertices, 3)), np.empty(3 * rig.n_vertices, dtype=np.float32))
        _buffers[info["id"]] = buf
    rig.deform(pose, fairing_steps=int(info["fairing_steps"]), method=str(info["method"]).lower(), out=buf[0])
    np.copyto(buf[1], buf[0].ravel())
    return buf


def update_object(obj, force=False):
    """Recomputes the shape key of a bound object if its armature's pose changed."""
    info = obj[PROP]
    arm = bpy.data.objects.get(info["armature"])
    if arm is None or arm.type != 'ARMATURE':
        return False
    names = list(info["bones"])
    if any(n not in arm.pose.bones for n in names):
        return False
    pose = _pose_matrices(obj, arm, names)
    sig = pose.tobytes()
    if not force and _last_pose.get(info["id"]) == sig:
        return False
    kb = obj.data.shape_keys.key_blocks.get(KEY) if obj.data.shape_keys else None
    if kb is None:
        return False
    _, co = _deformed(obj, pose)
    kb.data.foreach_set("co", co)
    obj.data.update()
    _last_pose[info["id"]] = sig
    return True


@bpy.app.handlers.persistent
def _on_update(scene, depsgraph=None):
    global _updating
    if _updating:
        return
    _updating = True
    try:
        for obj in scene.objects:
            if is_bound(obj):
                try:
                    update_object(obj)
                except Exception as exc:  # a handler must never take Blender down
                    print(f"dgmesh skeletal: update of {obj.name!r} failed: {exc}")
    finally:
        _updating = False


@bpy.app.handlers.persistent
def _on_load(*_args):
    _rigs.clear()
    _last_pose.clear()
    _buffers.clear()


def _add_handlers():
    for lst, fn in ((bpy.app.handlers.depsgraph_update_post, _on_update),
                    (bpy.app.handlers.frame_change_post, _on_update),
                    (bpy.app.handlers.load_post, _on_load)):
        for h in [h for h in lst if getattr(h, "__name__", "") == fn.__name__]:
            lst.remove(h)
        lst.append(fn)


def _remove_handlers():
    for lst in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.frame_change_post,
                bpy.app.handlers.load_post):
        for h in [h for h in lst if getattr(h, "__name__", "") in ("_on_update", "_on_load")]:
            lst.remove(h)


def _skeleton_object(context, obj, rig):
    """Hidden mesh object with the skeletal mesh and its radius colouring (fig. 6.8)."""
    name = obj.name + "_skeleton"
    me = bpy.data.meshes.new(name)
    S = rig.skeleton_vertices
    me.from_pydata([tuple(p) for p in S], [], [tuple(int(i) for i in f) for f in rig.control_faces])
    me.update()
    rgba = colors.sequential(rig.radii)
    bridge.write_point_float(me, "dg_radius", rig.radii)
    bridge.write_point_color(me, "dg_radius_color", rgba)
    sk = bpy.data.objects.new(name, me)
    for coll in obj.users_collection:
        coll.objects.link(sk)
    sk.parent = obj
    sk.hide_set(True)
    sk.hide_render = True
    return sk


class DGMESH_OT_skeletal_bind(bpy.types.Operator):
    """Bind the active mesh to the selected armature's deform bones: posing then keeps the \
mesh's thickness (no collapsing joints or candy wrappers)"""

    bl_idname = "dgmesh.skeletal_bind"
    bl_label = "Skeletal Bind"
    bl_options = {'REGISTER', 'UNDO'}

    control_faces: IntProperty(name="Control Faces", default=5000, min=200, max=200000,
                               description="Meshes with more faces are deformed through a decimated control "
                               "mesh of about this many faces (multiresolution)")
    fairing_steps: IntProperty(name="Fairing Steps", default=2, min=0, max=20,
                               description="Shape-preserving self-intersection fairing steps per pose (eq. 6.15)")
    method: EnumProperty(name="Method", items=METHODS, default='VARIATIONAL')

    @classmethod
    def register(cls):
        _add_handlers()

    @classmethod
    def unregister(cls):
        _remove_handlers()

    @classmethod
    def poll(cls, context):
        if context.mode != 'OBJECT':
            return _poll_fail(cls, "Switch to Object mode")
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            return _poll_fail(cls, "The active object must be a mesh")
        return True

    def execute(self, context):
        obj = context.active_object
        if is_bound(obj):
            self.report({'ERROR'}, f"{obj.name!r} is already bound; unbind it first (DG Mesh > Skeletal Unbind)")
            return {'CANCELLED'}
        arm = _armature_of(context, obj)
        if arm is None:
            self.report({'ERROR'}, "No armature: select an armature together with the mesh (or give the mesh an "
                        "Armature modifier)")
            return {'CANCELLED'}
        names = [b.name for b in arm.data.bones if b.use_deform]
        if not names:
            self.report({'ERROR'}, f"Armature {arm.name!r} has no deform bones")
            return {'CANCELLED'}
        if obj.data.shape_keys and KEY in obj.data.shape_keys.key_blocks:
            self.report({'ERROR'}, f"{obj.name!r} already has a shape key {KEY!r}; remove it first")
            return {'CANCELLED'}
        arrays = bridge.read_mesh(obj.data)
        V, F = arrays.V, arrays.F
        groups = {g.name: g.index for g in obj.vertex_groups}
        W = None
        if any(n in groups for n in names):
            W = np.zeros((len(V), len(names)))
            col = {groups[n]: j for j, n in enumerate(names) if n in groups}
            for v in obj.data.vertices:
                for g in v.groups:
                    j = col.get(g.group)
                    if j is not None:
                        W[v.index, j] = g.weight
        rest = _pose_matrices(obj, arm, names, rest=True)
        to_mesh = obj.matrix_world.inverted() @ arm.matrix_world
        heads = np.array([tuple(to_mesh @ arm.data.bones[n].head_local) for n in names])
        tails = np.array([tuple(to_mesh @ arm.data.bones[n].tail_local) for n in names])
        wm = context.window_manager
        has_window = context.window is not None
        if has_window:
            wm.progress_begin(0, 100)
        try:
            rig = SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails,
                                   control_faces=self.control_faces,
                                   progress=(lambda f: wm.progress_update(int(100 * f)) or True) if has_window else None)
        except MeshError as exc:
            msg = str(exc)
            if "no weight" in msg:
                msg += " (vertex groups must be named after deform bones: " + ", ".join(names[:8]) + ")"
            self.report({'ERROR'}, msg)
            return {'CANCELLED'}
        finally:
            if has_window:
                wm.progress_end()
        bid = uuid.uuid4().hex
        disabled = []
        for m in obj.modifiers:
            if m.type == 'ARMATURE' and (m.show_viewport or m.show_render):
                disabled.append([m.name, int(m.show_viewport), int(m.show_render)])
                m.show_viewport = False
                m.show_render = False
        created_basis = obj.data.shape_keys is None
        if created_basis:
            obj.shape_key_add(name="Basis", from_mix=False)
        kb = obj.shape_key_add(name=KEY, from_mix=False)
        kb.value = 1.0
        sk = _skeleton_object(context, obj, rig)
        obj[PROP] = {
            "id": bid, "armature": arm.name, "bones": names, "data": _encode(rig.to_arrays()),
            "fairing_steps": self.fairing_steps, "method": self.method, "created_basis": int(created_basis),
            "modifiers": [m[0] for m in disabled], "modifiers_viewport": [m[1] for m in disabled],
            "modifiers_render": [m[2] for m in disabled], "skeleton": sk.name,
        }
        _rigs[bid] = rig
        update_object(obj, force=True)
        self.report({'INFO'}, f"Bound {obj.name!r} ({len(V)} vertices, control mesh {rig.n_control} vertices) to "
                    f"{len(names)} deform bones of {arm.name!r}" + ("" if W is not None else
                                                                  " with distance weights (no vertex groups)"))
        return {'FINISHED'}


def unbind(obj):
    info = obj[PROP]
    _rigs.pop(info["id"], None)
    _last_pose.pop(info["id"], None)
    _buffers.pop(info["id"], None)
    keys = obj.data.shape_keys
    if keys and KEY in keys.key_blocks:
        obj.shape_key_remove(keys.key_blocks[KEY])
    keys = obj.data.shape_keys
    if info["created_basis"] and keys and len(keys.key_blocks) == 1:
        obj.shape_key_remove(keys.key_blocks[0])
    for name, vp, rd in zip(info["modifiers"], info["modifiers_viewport"], info["modifiers_render"]):
        m = obj.modifiers.get(name)
        if m is not None:
            m.show_viewport, m.show_render = bool(vp), bool(rd)
    sk = bpy.data.objects.get(info["skeleton"])
    if sk is not None:
        me = sk.data
        bpy.data.objects.remove(sk)
        if me.users == 0:
            bpy.data.meshes.remove(me)
    del obj[PROP]


class DGMESH_OT_skeletal_unbind(bpy.types.Operator):
    """Remove the skeletal binding: the shape key, the skeleton object and the stored data; the \
Armature modifiers are restored"""

    bl_idname = "dgmesh.skeletal_unbind"
    bl_label = "Skeletal Unbind"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        if context.mode != 'OBJECT':
            return _poll_fail(cls, "Switch to Object mode")
        return True

    def execute(self, context):
        obj = context.active_object
        if not is_bound(obj):
            self.report({'ERROR'}, "The active object is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        unbind(obj)
        self.report({'INFO'}, f"Unbound {obj.name!r}")
        return {'FINISHED'}


def write_pc2(path, frames, start, rate=1.0):
    """Writes (nframes, n, 3) positions as a PC2 point cache."""
    frames = np.ascontiguousarray(frames, dtype=np.float32)
    with open(path, "wb") as f:
        f.write(struct.pack("<12siiffi", b"POINTCACHE2\0", 1, frames.shape[1], float(start), float(rate),
                            frames.shape[0]))
        f.write(frames.tobytes())


class DGMESH_OT_skeletal_bake(bpy.types.Operator):
    """Bake the skeletal deformation of a frame range to a .pc2 point cache played by a Mesh \
Cache modifier (renders and exports then need no add-on)"""

    bl_idname = "dgmesh.skeletal_bake"
    bl_label = "Skeletal Bake"
    bl_options = {'REGISTER', 'UNDO'}

    filepath: StringProperty(name="File", subtype='FILE_PATH', default="//skeletal.pc2")
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)

    @classmethod
    def poll(cls, context):
        return context.mode == 'OBJECT'

    def invoke(self, context, event):
        self.frame_start, self.frame_end = context.scene.frame_start, context.scene.frame_end
        return self.execute(context)

    def execute(self, context):
        obj = context.active_object
        if not is_bound(obj):
            self.report({'ERROR'}, "The active object is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        if self.frame_end < self.frame_start:
            self.report({'ERROR'}, f"Frame range {self.frame_start}..{self.frame_end} is empty")
            return {'CANCELLED'}
        path = bpy.path.abspath(self.filepath)
        if self.filepath.startswith("//") and not bpy.data.filepath:
            self.report({'ERROR'}, "Save the .blend first or give an absolute path for the cache")
            return {'CANCELLED'}
        info = obj[PROP]
        arm = bpy.data.objects.get(info["armature"])
        if arm is None:
            self.report({'ERROR'}, f"Armature {info['armature']!r} is gone")
            return {'CANCELLED'}
        scene = context.scene
        current = scene.frame_current
        frames = []
        try:
            for fr in range(self.frame_start, self.frame_end + 1):
                scene.frame_set(fr)
                frames.append(_deformed(obj, _pose_matrices(obj, arm, list(info["bones"])))[0].copy())
        finally:
            scene.frame_set(current)
        try:
            write_pc2(path, np.array(frames), self.frame_start)
        except OSError as exc:
            self.report({'ERROR'}, f"Cannot write {path}: {exc}")
            return {'CANCELLED'}
        mod = obj.modifiers.get("dg_skeletal_cache") or obj.modifiers.new("dg_skeletal_cache", 'MESH_CACHE')
        mod.cache_format = 'PC2'
        mod.filepath = self.filepath
        mod.frame_start = self.frame_start
        self.report({'INFO'}, f"Baked {len(frames)} frames of {obj.name!r} to {path}")
        return {'FINISHED'}


classes = (DGMESH_OT_skeletal_bind, DGMESH_OT_skeletal_unbind, DGMESH_OT_skeletal_bake)
