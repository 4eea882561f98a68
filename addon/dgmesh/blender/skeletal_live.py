"""Live update of skeletally bound meshes: the depsgraph / frame-change / load / undo handlers,
the hidden helper object and its node group, and unbinding (see ops_skeletal.py for the operators).

Live update. The basis is never changed: each pose's displacement from the rest positions goes to
the vertex positions of a hidden helper object ``<mesh>_dg_offsets`` (a mesh of loose vertices, one
per vertex of the bound mesh, never drawn, rendered or selectable), which a geometry-nodes modifier
``dg_skeletal`` placed first in the stack reads (Object Info, Original space -> Sample Index by
vertex index -> Set Position offset), so other shape keys still add their deltas and later
modifiers see the deformed mesh. A depsgraph / frame-change handler refreshes the helper when the
pose changes (Pose mode, timeline, renders, ``frame_set`` in --background), once per pose change:
the pose matrices are compared with the last ones, and the write itself does not re-enter the
handler. Why a helper object: writing to the bound mesh itself (an attribute, or a shape key)
tags its datablock, and Blender then copies the whole original mesh (every layer, vertex groups
included) for evaluation before running the modifiers; a changed helper only re-runs the modifier
stack on the untouched original (bench ``skeletal_live``: about 20 ms less per frame at 178K
vertices). A shape key is slower still: in Blender 3.4 ``ShapeKey.data`` has no raw-array path
(``foreach_set`` 16 ms at 178K vertices against 0.8 ms here: bench skeletal_live).
Objects bound by earlier versions keep working through their own target: the point attribute
``dg_skeletal_offset`` read by a Named Attribute node, or the shape key ``dg_skeletal``.
A duplicated bound object (Shift+D) shares the bind data; at its first update it gets a helper and
a node group of its own, since it follows its own armature (the copied rig, when the rig was
duplicated with it) from its own place.
"""

import contextlib

import bpy
import numpy as np

from ..core import MeshError
from ..skeletal_data import render_untangle, saved_options
from . import compat
from .common import editable_collections
from .skeletal_space import inverse, pose_matrices, stored_space, transformed
from .skeletal_store import (ARM_PTR, ARM_TAG, ATTR, HELPER_NODE, HELPER_SUFFIX, KEY, NODE_GROUP, OWNER, PROP,
                             SKELETON_NODE, SKELETON_OF, bound_armature, bound_rig, helper_of, helper_users, hide_everywhere,
                             is_bound, live_modifier, purge_orphans, release_deleted_armature, rest_hash, rigs,
                             salvaged, skeleton_of, state_key, target_of, uses_shape_key)

_last_pose = {}     # (bind id, object name) -> bytes of the last pose matrices; per object, since a
                    # duplicated object shares the bind id but has its own attribute (and armature)
_updating = False   # re-entrancy guard: writing the offsets tags the mesh (another depsgraph update)
_rest_ok = {}  # (bind id, object name) -> the mesh's vertices are the ones bound (checked once per load)
_buffers = {}  # (bind id, object name) -> (positions (n, 3), float32 (n*3,) output, float32 (n*3,) rest)
_skeleton_rest = {}  # (bind id, object name) -> (the skeleton as its object holds it (float32), rig space)
_failed = set()  # the console notes of failed updates printed (each once)
_n_objects = 0  # len(bpy.data.objects) at the last update
_for_render = False  # the render settings in every update (Skeletal Bake with its Render evaluation)


@contextlib.contextmanager
def render_settings(on=True):
    """Within it every live update deforms with the bindings' render settings (Untangle Creases
    Render), as a render's own depsgraph does: for a bake whose cache plays in renders."""
    global _for_render
    before, _for_render = _for_render, bool(on)
    try:
        yield
    finally:
        _for_render = before


def writes_helper(obj, helper):
    """Whether ``obj`` writes the helper it reads: it is the helper's owner. A duplicate (Shift+D)
    reads the original's helper until it gets its own (``own_helper``). The owner is claimed by the
    first reader when the recorded one is gone, renamed or no longer reads it."""
    owner = helper.get(OWNER)
    if owner == obj.name:
        return True
    o = bpy.data.objects.get(owner) if isinstance(owner, str) else None
    if o is not None and is_bound(o) and target_of(o[PROP]) == "HELPER" and helper_of(o, o[PROP]) == helper:
        return False
    helper[OWNER] = obj.name
    return True


def writable(helper, adopt=True):
    """``helper``, or None when its vertices cannot be written. A character linked from a library and
    overridden (Make Library Override) has an override helper whose mesh is still library data,
    which ignores writes: the override takes a local copy once (``adopt``; saved with the file)."""
    if helper.data.library is None:
        return helper
    if not adopt or helper.library is not None or helper.override_library is None:
        return None
    helper.data = helper.data.copy()
    return helper


def own_helper(obj, info, shared):
    """A duplicate (Shift+D) reads the original's helper through a copy of its modifier: gives it a
    helper and a node group of its own, as the copy deforms by its own pose (its parent may be the
    copied rig) and in its own place relative to the rig. None if its modifier is not ours."""
    mod = live_modifier(obj, info)
    ng = mod.node_group if mod is not None else None
    if ng is None or ng.nodes.get(HELPER_NODE) is None:
        return None
    helper = helper_object(obj, len(shared.data.vertices))
    ng = ng.copy()
    ng.nodes[HELPER_NODE].inputs["Object"].default_value = helper
    mod.node_group = ng
    info["helper"], info["node_group"] = helper.name, ng.name
    return helper


def replace_helper(obj, info, n):
    """A new helper for one deleted by hand (the Outliner's Blender File view removes it): the
    mesh showed at rest, silently, until unbound. None if the live modifier is not ours."""
    mod = live_modifier(obj, info)
    ng = mod.node_group if mod is not None else None
    node = ng.nodes.get(HELPER_NODE) if ng is not None else None
    if node is None:
        return None
    old = bpy.data.meshes.get(obj.name + HELPER_SUFFIX)
    if old is not None and old.users == 0:  # the deleted helper's mesh
        bpy.data.meshes.remove(old)
    helper = helper_object(obj, n)
    node.inputs["Object"].default_value = helper
    info["helper"] = helper.name
    print(f"dgmesh skeletal: the helper object of {obj.name!r} was deleted: made again")
    return helper


def edited(obj, info):
    """The mesh was edited since it was bound: another vertex count, or (checked at load, after
    Edit or Sculpt mode and after undo, as hashing every frame would cost milliseconds) other rest
    positions (moved or reordered vertices). Offsets made for the bound vertices would scramble it."""
    if len(obj.data.vertices) != bound_rig(obj).n_vertices:
        return True
    key = state_key(obj, info)
    if key not in _rest_ok:
        _rest_ok[key] = info.get("rest_hash") in (None, rest_hash(obj.data))  # None: bound before the hash
    return not _rest_ok[key]


def follow_renamed_bones(obj, arm, info, names):
    """The bound bone names, following bones renamed since bind: a bone is found by its rest frame
    (``bones_local``, stored at bind) and the mesh's vertex group of the old name takes the new one,
    as Blender does for meshes its Armature modifier deforms (ours is cleared while bound, so Blender
    does not). Bones that are gone stay missing."""
    stored = info.get("bones_local")
    if stored is None or len(stored) != 16 * len(names):
        return names
    stored = np.array(stored, dtype=float).reshape(-1, 4, 4)
    free = [b for b in arm.data.bones if b.name not in names]
    new = list(names)
    for j, name in enumerate(names):
        if name in arm.pose.bones:
            continue
        tol = 1e-5 * max(1.0, float(np.abs(stored[j]).max()))
        match = [b for b in free if float(np.abs(np.array(b.matrix_local) - stored[j]).max()) <= tol]
        if len(match) != 1:
            continue
        bone = match[0]
        free.remove(bone)
        new[j] = bone.name
        group = obj.vertex_groups.get(name)
        if group is not None and obj.vertex_groups.get(bone.name) is None:
            group.name = bone.name
    if new != names:
        info["bones"] = new
        print(f"dgmesh skeletal: {obj.name!r} follows renamed bones: "
              + ", ".join(f"{a} -> {b}" for a, b in zip(names, new) if a != b))
    return new


def clear_live(obj, info, why, note):
    """Zero offsets (the mesh shows undeformed) for an edited mesh or a deleted armature (``why``),
    once, with a console note."""
    key = state_key(obj, info)
    if _last_pose.get(key) == why or target_of(info) != "HELPER":
        return
    h = helper_of(obj, info)
    if h is not None and not writes_helper(obj, h):
        h = own_helper(obj, info, h)  # an edited duplicate: the original's offsets are not its own
    if h is not None:
        h = writable(h)
    if h is None:
        return
    h.data.vertices.foreach_set("co", np.zeros(3 * len(h.data.vertices), dtype=np.float32))
    h.data.update()
    _last_pose[key] = why
    print(f"dgmesh skeletal: {obj.name!r} {note}")


def shown_undeformed(obj):
    """Whether a bound object is shown undeformed because it was edited since bind (the sidebar
    panel says so)."""
    return is_bound(obj) and _last_pose.get(state_key(obj, obj[PROP])) == b"edited"


def new_buffers(obj, rig):
    """Positions (float32: the native deform rounds on output), the float32 array handed to
    foreach_set and the float32 rest positions (the basis: what bind read)."""
    n = rig.n_vertices
    rest = np.empty(3 * n, dtype=np.float32)
    if len(obj.data.vertices) == n:
        obj.data.vertices.foreach_get("co", rest)
    return np.empty((n, 3), dtype=np.float32), np.empty(3 * n, dtype=np.float32), rest


def skeleton_edit(obj, info, depsgraph=None):
    """Free-form skeleton editing (thesis 6.2): the skeletal vertices in rig space as the skeleton
    object shows them (its mesh as edited or sculpted, its shape keys and its modifiers: Lattice,
    Hook, Curve, Simple Deform...), evaluated in ``depsgraph`` (the original mesh without one);
    None when no vertex moved from the bound skeleton, or when the skeleton is gone or a modifier
    changed its vertex count. The live modifier's node group refers to the skeleton object, so
    every depsgraph evaluates it, hidden or not, renders included."""
    sk = skeleton_of(obj)
    if sk is None:
        return None
    rig = bound_rig(obj)
    n = rig.n_control
    co = _skeleton_co(sk.evaluated_get(depsgraph) if depsgraph is not None else sk, n)
    if co is None:
        return None
    key = state_key(obj, info)
    rest = _skeleton_rest.get(key)
    space = stored_space(info)
    if rest is None or rest[0].shape[0] != n:
        S = rig.skeleton_vertices
        shown = transformed(S, inverse(space)) if space is not None else S  # as skeleton_object wrote it
        rest = _skeleton_rest[key] = (shown.astype(np.float32), S)
    moved = np.abs(co - rest[0]).max(axis=1) > 1e-6 * max(float(np.ptp(rest[0], axis=0).max()), 1e-30)
    if not moved.any():
        return None
    edit = co.astype(np.float64)
    if space is not None:
        edit = transformed(edit, space)
    edit[~moved] = rest[1][~moved]  # exactly the bound skeleton where nothing moved (float32 storage)
    return edit


def _skeleton_co(src, n):
    """(n, 3) float32 vertex positions of the (evaluated) skeleton object, or None when it has not n
    vertices. In Edit mode an evaluated mesh wraps the edit-mesh and shows no vertices until
    converted: to_mesh() reads the edit as it is."""
    me = src.data
    if me is not None and len(me.vertices) == 0 and src.mode == 'EDIT' and src.is_evaluated:
        me = src.to_mesh()
        try:
            return _skeleton_co_of(me, n)
        finally:
            src.to_mesh_clear()
    return _skeleton_co_of(me, n)


def _skeleton_co_of(me, n):
    if me is None or len(me.vertices) != n:
        return None
    co = np.empty(3 * n, dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def deformed(obj, pose, skeleton=None, render=False):
    """Deforms into the object's reused buffers: (positions (n, 3), float32 (n*3,) ready for
    foreach_set: the positions for a legacy shape key, else the offsets from the rest positions).
    ``skeleton``: an edited skeleton (skeleton_edit). ``render``: with the binding's render settings
    (its Untangle Creases Render iterations instead of the viewport's)."""
    info = obj[PROP]
    rig = bound_rig(obj)
    key = state_key(obj, info)
    buf = _buffers.get(key)
    if buf is None or buf[0].shape[0] != rig.n_vertices:
        buf = _buffers[key] = new_buffers(obj, rig)
    pos, out, rest = buf
    saved = saved_options(info)  # files bound before an option: the values they were bound with
    kw = dict(fairing_steps=int(info["fairing_steps"]), method=str(info["method"]).lower(),
              bone_clearance=saved["bone_clearance"],
              untangle_iterations=render_untangle(info) if render else saved["untangle_iterations"],
              fold_guard=saved["fold_guard"], contact_slide=saved["contact_slide"],
              follow_twist=saved["follow_twist"], integrate_skeleton=saved["integrate_skeleton"],
              ring_twist=saved["ring_twist"], joint_fillet=saved["joint_fillet"],
              dual_quaternion=saved["skeleton_blend"] == 'DUAL_QUATERNION')
    try:
        rig.deform(pose, out=pos, skeleton=skeleton, **kw)
    except (MeshError, TypeError):
        if pos.dtype != np.float32:
            raise
        # A native module without float32 output: deform in float64 from now on.
        pos = np.empty(pos.shape)
        buf = _buffers[key] = (pos, out, rest)
        rig.deform(pose, out=pos, skeleton=skeleton, **kw)
    space = stored_space(info)
    if space is not None:  # rig space -> the mesh's object space
        pos[:] = transformed(pos, inverse(space))
    if uses_shape_key(info):
        np.copyto(out, pos.ravel())
    else:
        np.subtract(pos.ravel(), rest, out=out, casting="same_kind")  # float32 offsets, no temporary
    return buf


def live_target(obj, info, adopt=True):
    """The foreach_set target of the live update: (collection, property, mesh to tag) of the helper's
    vertices (or a legacy binding's attribute or shape key); Nones when it is missing or when the
    vertex count changed since bind (mesh edited). A duplicate still reading the original's helper
    gets its own first (``adopt``: not while a render evaluates, which must not add objects; it
    shows the original's deformation until then)."""
    none = None, None, None
    n = bound_rig(obj).n_vertices
    if len(obj.data.vertices) != n:
        return none
    target = target_of(info)
    if target == "HELPER":
        h = helper_of(obj, info)
        if h is None and adopt:
            h = replace_helper(obj, info, n)
        elif h is not None and not writes_helper(obj, h):
            h = own_helper(obj, info, h) if adopt else None
        if h is not None:
            h = writable(h, adopt)
        if h is None or len(h.data.vertices) != n:
            return none
        return h.data.vertices, "co", h.data
    if target == "SHAPE_KEY":
        kb = obj.data.shape_keys.key_blocks.get(KEY) if obj.data.shape_keys else None
        return (kb.data, "co", obj.data) if kb is not None else none
    att = obj.data.attributes.get(ATTR)
    if att is None or att.data_type != 'FLOAT_VECTOR' or att.domain != 'POINT':
        return none
    return att.data, "vector", obj.data


def update_object(obj, force=False, depsgraph=None):
    """Recomputes the live deformation of a bound object if its armature's pose changed; True if
    it wrote. One native deform and one float32 ``foreach_set`` per pose change. The pose is read
    from ``depsgraph``'s evaluated armature when given: a render of an animation evaluates each
    frame in its own depsgraph and never writes the animated pose back to the original armature
    (only the view layer's depsgraph does), so the original's pose stays at the frame the render
    started from."""
    info = obj[PROP]
    if target_of(info) == "HELPER" and live_modifier(obj, info) is None:
        # The user removed or applied the live modifier: nothing shows the binding any more, so it
        # goes (helper, skeleton, stored data), as with unbind. The Armature modifiers come back, but
        # disabled when it was applied in a pose (the rest positions changed by the helper's offsets:
        # the mesh holds the pose; at rest the offsets are rounding and the positions barely move).
        if depsgraph is None or depsgraph.mode != 'RENDER':
            h = helper_of(obj, info)
            co = np.empty(3 * len(obj.data.vertices), dtype=np.float32)
            obj.data.vertices.foreach_get("co", co)
            posed = True
            if h is not None and len(h.data.vertices) and len(co):
                off = np.empty(3 * len(h.data.vertices), dtype=np.float32)
                h.data.vertices.foreach_get("co", off)
                posed = float(np.abs(off).max()) > 1e-5 * float(np.ptp(co.reshape(-1, 3), axis=0).max())
            applied = len(obj.data.vertices) != bound_rig(obj).n_vertices or (posed and rest_hash(obj.data) != info.get(
                "rest_hash", rest_hash(obj.data)))
            unbind(obj, enable_armature=not applied)
            purge_orphans()
            print(f"dgmesh skeletal: the live modifier of {obj.name!r} was "
                  + ("applied: unbound (its Armature modifiers are back, disabled)" if applied else "removed: unbound"))
        return False
    arm = bound_armature(obj, info)
    if arm is None:
        clear_live(obj, info, b"no armature", "its armature is gone: shown at rest (Skeletal Unbind restores "
                    "its modifiers)")
        if depsgraph is None or depsgraph.mode != 'RENDER':
            release_deleted_armature(obj)
        return False
    names = list(info["bones"])
    if any(n not in arm.pose.bones for n in names) and (depsgraph is None or depsgraph.mode != 'RENDER'):
        names = follow_renamed_bones(obj, arm, info, names)
    missing = [n for n in names if n not in arm.pose.bones]
    if missing:
        clear_live(obj, info, b"bones", f"has bones missing from {arm.name!r} ({', '.join(missing[:4])}): shown "
                    "at rest; name them back, or Skeletal Rebind")
        return False
    if edited(obj, info):
        clear_live(obj, info, b"edited", "was edited since it was bound (vertex count or positions): shown "
                    "undeformed; Skeletal Rebind binds it again")
        return False
    space = stored_space(info)
    bind = info.get("bind_to_mesh")
    bind = None if bind is None else np.array(bind, dtype=float).reshape(4, 4)
    if depsgraph is not None:
        pose = pose_matrices(obj.evaluated_get(depsgraph), arm.evaluated_get(depsgraph), names, space=space,
                              bind=bind)
    else:
        pose = pose_matrices(obj, arm, names, space=space, bind=bind)
    skeleton = skeleton_edit(obj, info, depsgraph)
    # A render's depsgraph (and a bake for renders) deforms with the render settings; the signature
    # holds which, so the viewport's next update of the same pose writes its own result again.
    render = _for_render or (depsgraph is not None and depsgraph.mode == 'RENDER')
    sig = pose.tobytes() + (b"" if skeleton is None else skeleton.tobytes()) + (b"R" if render else b"")
    # Same pose and skeleton: nothing to write, unless the helper was deleted by hand (live_target
    # makes it again, with this pose's offsets).
    if not force and _last_pose.get(state_key(obj, info)) == sig and (
            target_of(info) != "HELPER" or helper_of(obj, info) is not None):
        return False
    data, prop, tagged = live_target(obj, info, adopt=depsgraph is None or depsgraph.mode != 'RENDER')
    if data is None:
        return False
    _, co, _ = deformed(obj, pose, skeleton, render)
    data.foreach_set(prop, co)
    tagged.update()
    _last_pose[state_key(obj, info)] = sig
    return True


@bpy.app.handlers.persistent
def on_update(scene, depsgraph=None):
    """depsgraph_update_post / frame_change_post handler: updates the bound objects of ``scene``."""
    global _updating, _n_objects
    if _updating:
        return
    _updating = True
    try:
        wrote = False
        # A bound mesh deleted: its hidden helper and skeleton objects go too (the user cannot find
        # them). Checked when the file has fewer objects than at the last update (cheap otherwise).
        if len(bpy.data.objects) < _n_objects and (depsgraph is None or depsgraph.mode != 'RENDER'):
            purge_orphans(deleted_only=True)
        _n_objects = len(bpy.data.objects)
        # The bound objects first: an update may unbind one (its live modifier removed), removing its
        # helper and skeleton objects, and removing objects while iterating scene.objects crashes 4.x.
        for obj in [o for o in scene.objects if is_bound(o)]:
            # In Edit mode the edit-mesh owns the data (attribute arrays are empty): wait for Object
            # mode. Edit and Sculpt mode may move or reorder the vertices (Sort Elements): check the
            # rest positions again when the object is back.
            try:
                if obj.mode in ('EDIT', 'SCULPT'):
                    _rest_ok.pop(state_key(obj, obj[PROP]), None)
                else:
                    wrote |= update_object(obj, depsgraph=depsgraph)
            except Exception as exc:  # a handler must never take Blender down (a damaged binding:
                note = f"dgmesh skeletal: update of {obj.name!r} failed: {exc}"  # once, not every frame)
                if note not in _failed:
                    _failed.add(note)
                    print(note)
        # A render's depsgraph has evaluated this frame before the handler wrote the offsets, and
        # nothing evaluates it again before the frame is drawn (the view layer's does, after
        # frame_set): re-evaluate what the write changed.
        if wrote and depsgraph is not None and depsgraph.mode == 'RENDER':
            depsgraph.update()
    finally:
        _updating = False


@bpy.app.handlers.persistent
def on_load(*_args):
    """load_post handler: removes orphaned internal objects, readies overridden helpers, forgets the
    previous file's caches."""
    purge_orphans()
    for o in bpy.data.objects:  # helpers of files bound before they were disabled in viewports
        if OWNER in o.keys() and not o.hide_viewport and o.library is None:
            o.hide_viewport = True
    # Overridden characters saved before any update gave their helper a local mesh: now, before a
    # render (`blender -b shot.blend -a`), whose handler calls may not add data.
    for o in bpy.data.objects:
        if o.override_library is not None and is_bound(o) and target_of(o[PROP]) == "HELPER":
            h = helper_of(o, o[PROP])
            if h is not None:
                writable(h)
    _rest_ok.clear()
    rigs.clear()
    _last_pose.clear()
    _buffers.clear()
    _skeleton_rest.clear()
    _failed.clear()


@bpy.app.handlers.persistent
def on_undo(*_args):
    """undo_post / redo_post handler: forgets the last poses and the checked rest positions."""
    # Undo restores the pose and the attribute from one snapshot, but not our cache of the last
    # pose: forget it so the next update recomputes instead of trusting a stale signature. It may
    # also undo an edit of a bound mesh: check the rest positions again.
    _last_pose.clear()
    _rest_ok.clear()


HANDLERS = (("depsgraph_update_post", on_update), ("frame_change_post", on_update),
             ("load_post", on_load), ("undo_post", on_undo), ("redo_post", on_undo))


def set_position_group():
    """A node group Group Input -> Set Position -> Group Output: (group, Set Position node)."""
    ng = compat.new_geometry_node_group(NODE_GROUP)
    nodes = ng.nodes
    gi, go = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    sp = nodes.new('GeometryNodeSetPosition')
    ng.links.new(gi.outputs[0], sp.inputs["Geometry"])
    ng.links.new(sp.outputs["Geometry"], go.inputs[0])
    gi.location, sp.location, go.location = (-400, 0), (-150, 0), (100, 0)
    ng.use_fake_user = False
    return ng, sp


def enabled_socket(sockets, name, kind='VECTOR'):
    """The socket of that name and type: 3.x nodes have one per data type, only the chosen enabled."""
    return next(s for s in sockets if s.name == name and s.type == kind and getattr(s, "enabled", True))


def link_skeleton(ng, skeleton):
    """Makes a live node group refer to the skeleton object by an unlinked Object Info node: the
    mesh then depends on the skeleton, so every depsgraph evaluates it (modifiers included) even
    while it is hidden, and the live update reads its edits (skeleton_edit)."""
    node = ng.nodes.get(SKELETON_NODE)
    if node is None:
        node = ng.nodes.new('GeometryNodeObjectInfo')
        node.name = node.label = SKELETON_NODE
        node.location = (-650, -600)
    node.inputs["Object"].default_value = skeleton


def helper_node_group(helper):
    """Set Position (Offset = Sample Index(Object Info(helper, Original).Geometry, Position, Index)),
    on all points only when the geometry has as many points as the helper: moved below a modifier
    that changes the vertices (a Subdivision Surface), the offsets would scramble the mesh (Blender's
    Armature modifier keeps working there; ours shows the mesh undeformed and the panel says why)."""
    ng, sp = set_position_group()
    nodes = ng.nodes
    oi = nodes.new('GeometryNodeObjectInfo')
    oi.name = HELPER_NODE
    oi.transform_space = 'ORIGINAL'  # the helper's own coordinates: offsets in the mesh's object space
    oi.inputs["Object"].default_value = helper
    si = nodes.new('GeometryNodeSampleIndex')
    si.data_type, si.domain = 'FLOAT_VECTOR', 'POINT'
    pos, idx = nodes.new('GeometryNodeInputPosition'), nodes.new('GeometryNodeInputIndex')
    ng.links.new(oi.outputs["Geometry"], si.inputs["Geometry"])
    ng.links.new(pos.outputs[0], enabled_socket(si.inputs, "Value"))
    ng.links.new(idx.outputs[0], si.inputs["Index"])
    ng.links.new(enabled_socket(si.outputs, "Value"), sp.inputs["Offset"])
    gi = next(n for n in nodes if n.type == 'GROUP_INPUT')
    size_in, size_helper = nodes.new('GeometryNodeAttributeDomainSize'), nodes.new('GeometryNodeAttributeDomainSize')
    same = nodes.new('FunctionNodeCompare')
    same.data_type, same.operation = 'INT', 'EQUAL'
    ng.links.new(gi.outputs[0], size_in.inputs["Geometry"])
    ng.links.new(oi.outputs["Geometry"], size_helper.inputs["Geometry"])
    ng.links.new(size_in.outputs["Point Count"], enabled_socket(same.inputs, "A", 'INT'))
    ng.links.new(size_helper.outputs["Point Count"], enabled_socket(same.inputs, "B", 'INT'))
    ng.links.new(same.outputs[0], sp.inputs["Selection"])
    oi.location, pos.location, idx.location, si.location = (-650, -150), (-650, -350), (-650, -450), (-400, -150)
    size_in.location, size_helper.location, same.location = (-650, 200), (-650, 50), (-400, 150)
    return ng


def armature_modifier_on(obj):
    """Whether a bound object's Armature modifier deforms it as well (bind turned it off and cleared
    its armature; set back by hand, e.g. in a session without the add-on, both deformations add
    up): the sidebar panel says so."""
    return is_bound(obj) and any(m.type == 'ARMATURE' and m.object is not None and (m.show_viewport or m.show_render)
                                 for m in obj.modifiers)


def live_modifier_misplaced(obj):
    """Whether a bound object's live modifier comes after another modifier shown (its offsets are
    per vertex of the base mesh: the sidebar panel asks to move it back to the top)."""
    if not is_bound(obj) or target_of(obj[PROP]) != "HELPER":
        return False
    mod = live_modifier(obj, obj[PROP])
    if mod is None:
        return False
    shown = [m for m in obj.modifiers if m.show_viewport or m == mod]
    return shown[0] != mod


def helper_object(obj, n):
    """The hidden helper: ``n`` loose vertices at the origin (zero offsets: the rest pose), in the
    mesh's collections so the depsgraph evaluates it, never drawn, rendered or selectable. Blender
    suffixes the name if it is taken (a duplicate may still use an earlier helper of this name): the
    modifier's node group points at the object itself."""
    name = obj.name + HELPER_SUFFIX
    me = bpy.data.meshes.new(name)
    me.vertices.add(n)
    me.update()
    h = bpy.data.objects.new(name, me)
    for coll in editable_collections(obj) or [bpy.context.scene.collection]:
        coll.objects.link(h)
    hide_everywhere(h)
    # Disabled in viewports too: a collection instance ignores the view-layer hide and drew it (a
    # modifier's dependency is still evaluated).
    h.hide_viewport = True
    h.hide_render = True
    h.hide_select = True
    h.display_type = 'BOUNDS'
    h[OWNER] = obj.name
    return h


def offset_node_group():
    """Objects bound by the previous version: Set Position (Offset = Named Attribute ATTR)."""
    ng, sp = set_position_group()
    nodes = ng.nodes
    na = nodes.new('GeometryNodeInputNamedAttribute')
    na.data_type = 'FLOAT_VECTOR'
    na.inputs["Name"].default_value = ATTR
    # 3.x has one "Attribute" output per data type (only the chosen one enabled), 4.x one output.
    out = next(s for s in na.outputs if s.type == 'VECTOR' and getattr(s, "enabled", True))
    ng.links.new(out, sp.inputs["Offset"])
    na.location = (-400, -150)
    return ng


def move_first(obj, mod):
    """Puts a modifier first in the stack (shape keys apply before any modifier, so should we)."""
    compat.move_modifier(obj, mod, 0)


def unbind(obj, enable_armature=True):
    """Removes the binding and restores the Armature modifiers bind disabled (left disabled with
    ``enable_armature`` False: the mesh already holds a pose). Works on a damaged binding too (the
    property edited by hand): what its fields no longer say is found as for renamed parts, or left;
    returns the names of the fields that were unreadable."""
    info, lost = salvaged(obj)  # a copy: the ID property is deleted below
    for cache in (_last_pose, _buffers, _skeleton_rest):
        cache.pop(state_key(obj, info), None)
    if uses_shape_key(info):  # bound by an earlier version
        keys = obj.data.shape_keys
        if keys and KEY in keys.key_blocks:
            obj.shape_key_remove(keys.key_blocks[KEY])
        keys = obj.data.shape_keys
        if info.get("created_basis") and keys and len(keys.key_blocks) == 1:
            obj.shape_key_remove(keys.key_blocks[0])
    else:
        helper = helper_of(obj, info) if target_of(info) == "HELPER" else None
        mod = live_modifier(obj, info)
        ng = mod.node_group if mod is not None else None
        if mod is not None:
            obj.modifiers.remove(mod)
        if target_of(info) == "ATTRIBUTE":
            att = obj.data.attributes.get(ATTR)
            if att is not None:
                obj.data.attributes.remove(att)
        if ng is None:
            ng = bpy.data.node_groups.get(str(info.get("node_group", "")))
        if ng is not None and ng.users == 0:
            bpy.data.node_groups.remove(ng)
        # The helper goes with the last object reading it (a duplicate may still read it).
        if helper is not None and not helper_users(helper, exclude=obj):
            me = helper.data
            bpy.data.objects.remove(helper)
            if me.users == 0:
                bpy.data.meshes.remove(me)
    objects = info.get("modifiers_object", [None] * len(info["modifiers"]))
    arm = bound_armature(obj, info) if info["armature"] else None  # renamed since bind: found by its tag
    for name, vp, rd, ob in zip(info["modifiers"], info["modifiers_viewport"], info["modifiers_render"], objects):
        m = obj.modifiers.get(name)
        if m is None:  # renamed while bound: an Armature modifier still as bind left it (off, no object)
            m = next((x for x in obj.modifiers if x.type == 'ARMATURE' and x.object is None and not x.show_viewport
                      and not x.show_render and x.name not in info["modifiers"]), None)
        if m is not None:
            m.show_viewport, m.show_render = bool(vp) and enable_armature, bool(rd) and enable_armature
            if ob and m.object is None:
                m.object = arm if ob == info["armature"] else bpy.data.objects.get(ob)
    sk = bpy.data.objects.get(info["skeleton"])
    if sk is None or sk.parent != obj:  # renamed (or the name is lost): the one parented to the mesh
        sk = next((c for c in obj.children if c.get(SKELETON_OF) is not None), None)
    if sk is not None and sk.parent == obj:  # not the original's when unbinding a duplicate
        me = sk.data
        bpy.data.objects.remove(sk)
        if me.users == 0:
            bpy.data.meshes.remove(me)
    del obj[PROP]
    if ARM_PTR in obj.keys():
        del obj[ARM_PTR]
    tag = info.get("armature_tag")
    if tag and not any(is_bound(o) and o[PROP].get("armature_tag") == tag for o in bpy.data.objects):
        for a in bpy.data.objects:  # the last binding to this armature (and its copies, Shift+D)
            if a.type == 'ARMATURE' and a.get(ARM_TAG) == tag:
                del a[ARM_TAG]
    if not any(is_bound(o) and o[PROP].get("id") == info["id"] for o in bpy.data.objects):
        rigs.pop(info["id"], None)  # no duplicate left using this bind data
    return lost
