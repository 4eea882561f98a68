"""Operators dgmesh.skeletal_bind / skeletal_rebind / skeletal_unbind / skeletal_bake (thesis chapter 6).

Bind (a mesh and an armature selected, the mesh active): the mesh is bound to the armature's
deform bones with the weights of its vertex groups named after them (distance-based Gaussian
weights when it has none). The bind data is stored in the .blend (a custom property of the mesh
object holding the compressed arrays), plus a hidden object ``<mesh>_skeleton`` showing the
skeletal mesh coloured by its medial-ball radius (thesis fig. 6.8), revealed by DG Mesh > Show
Skeleton. Both internal objects are disabled in viewports, not only hidden, so collection instances
of a bound character do not draw them.

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
The armature is found by a tag custom property bind puts on it (renames keep the binding). Bone
motions are taken as the Armature modifier applies them in the mesh's current object space, so
moving either object later behaves as with the modifier; a mesh whose transform relative to the
armature is not a similarity (unapplied non-uniform or negative scale) is bound in the armature's
space, where bone frames stay rigid. The mesh also points at the armature (a custom property that
Blender remaps when mesh and rig are duplicated together); with the armature deleted, the mesh shows
at rest. A mesh edited after bind (vertex count, or positions: checked
at load, after Edit or Sculpt mode and after undo) shows undeformed until it is bound again;
Rebind does that with the armature and settings it had (weights painted after bind need it too).
The mesh's own Armature modifiers are disabled while bound and restored on unbind; their armature
is cleared meanwhile too, because a disabled modifier still makes the mesh depend on the pose and
Blender would re-evaluate the whole mesh once more on every frame (measured: ~30 ms CPU per frame at
178K vertices) before the handler's write.

Live update covers the objects of the open file's scenes, library overrides included: a character
linked from a library and overridden (Make Library Override) deforms live once its override helper
takes a local copy of its mesh (library data ignores writes); binding, unbinding and rebinding it
are refused there (they belong to its own file). A plain collection instance cannot be posed, is not
in the scene's objects and stays at rest: bake it in its own file (the cache plays when linked).

Bake writes a frame range to a .pc2 point cache played by a Mesh Cache modifier, so renders and
exports need no add-on: each frame as the stack evaluates it up to the live deformation (shape keys
included), the cache placed after the live and Armature modifiers and before the others (a
Subdivision Surface still applies). Unbind removes everything bind added and leaves the mesh as it
was. Removing the live modifier unbinds as well; applying it does too, and keeps the pose it froze
into the mesh (the Armature modifiers come back disabled).
"""

import base64
import hashlib
import io
import struct
import uuid

import bpy
import mathutils
import numpy as np
from bpy.props import EnumProperty, FloatProperty, IntProperty, StringProperty

from .. import colors
from ..core import MeshError
from ..skeletal import SkeletalDeformOptions, SkeletalMethod, SkeletalRig, SkeletalRigOptions
from . import bridge, compat
from .common import (editable_collections, enum_id, enum_items, plural, poll_fail as _poll_fail, read_only_reason,
                     set_handlers)

PROP = "dg_skeletal"            # custom property (dict) on the mesh object
KEY = "dg_skeletal"             # shape key of objects bound by earlier versions (legacy live target)
ATTR = "dg_skeletal_offset"     # point attribute of objects bound by an earlier version (legacy live target)
HELPER_SUFFIX = "_dg_offsets"   # helper object: its vertex positions are deformed - rest positions
OWNER = "dg_skeletal_owner"     # custom property of the helper: the object that writes it
SKELETON_OF = "dg_skeleton_of"  # custom property of the skeleton object: the mesh it belongs to
ARM_TAG = "dg_skeletal_rig"     # custom property of a bound armature: finds it after a rename
ARM_PTR = "dg_skeletal_armature"  # custom property of the mesh object: the armature (an ID pointer,
                                  # which Blender remaps when mesh and rig are duplicated together)
HELPER_NODE = "dg_helper"       # the Object Info node of the node group (finds the helper after renames)
MOD = "dg_skeletal"             # geometry-nodes modifier adding the offsets to the positions
CACHE = "dg_skeletal_cache"     # the Mesh Cache modifier skeletal_bake adds
NODE_GROUP = "dg_skeletal"      # its node group
METHODS = enum_items(SkeletalMethod, {
    "variational": ("Variational", "Thesis 6.5: stitched per-triangle frames plus shape-preserving fairing"),
    "basic": ("Basic", "Thesis 6.3: homotopy reconstruction with fold and self-intersection fairing (comparison)"),
})
BIND_DEFAULTS = SkeletalRigOptions()  # property defaults: the library's own (dgmesh/skeletal.h)
DEFORM_DEFAULTS = SkeletalDeformOptions()
SKELETON_BLENDS = (
    ('DUAL_QUATERNION', "Dual Quaternion", "Rigid per skeletal vertex, as Preserve Volume: a thick "
     "limb turned far about itself keeps its shape (the linear blend collapses its medial surface "
     "halfway through the joint and the mesh tears open there)"),
    ('LINEAR', "Linear", "Skeletal subspace deformation (eq. 6.2), as the thesis: about even in bends, "
     "tears thick limbs twisted far"),
)

_rigs = {}          # bind id -> SkeletalRig (rebuilt from the stored data after a reload)
_last_pose = {}     # (bind id, object name) -> bytes of the last pose matrices; per object, since a
                    # duplicated object shares the bind id but has its own attribute (and armature)
_updating = False   # re-entrancy guard: writing the offsets tags the mesh (another depsgraph update)


def _bind_target(context):
    """The mesh Skeletal Bind acts on: the active object, or with the armature active (the order
    Ctrl+P parenting uses: mesh, then armature) the one selected mesh."""
    obj = context.active_object
    if obj is not None and obj.type == 'MESH':
        return obj
    if obj is not None and obj.type == 'ARMATURE':
        meshes = [o for o in context.selected_objects if o.type == 'MESH']
        if len(meshes) == 1:
            return meshes[0]
    return None


def _poll_bound(cls, context):
    """Object mode, with a bound active object."""
    if context.mode != 'OBJECT':
        return _poll_fail(cls, "Only available in Object mode")
    if not is_bound(context.active_object):
        return _poll_fail(cls, "The active object is not bound (DG Mesh > Skeletal Bind)")
    return True


def _armature_of(context, mesh_obj):
    for o in context.selected_objects:
        if o.type == 'ARMATURE' and o is not mesh_obj:
            return o
    for m in mesh_obj.modifiers:
        if m.type == 'ARMATURE' and m.object is not None:
            return m.object
    return None


# The rig-space maps call no numpy.linalg and no large matrix product: Debian's numpy runs them on
# OpenBLAS, which threads even a 4x4 inverse (dgetrs) and whose worker then spin-waits (sched_yield)
# for ~0.1 s on the cores the native deform's OpenMP loops need (measured: the deform in the frame
# handler at 30-40 ms instead of 15-19 ms). Blender's mathutils and numpy's elementwise loops do not.
def _inverse(M):
    """Inverse of a 4x4 matrix (array), without LAPACK."""
    return np.array(mathutils.Matrix(M.tolist()).inverted())


def _transformed(P, M):
    """Points (n, 3) mapped by the 4x4 affine matrix M, in P's dtype, without BLAS."""
    M = M.astype(P.dtype)
    out = P[:, :1] * M[:3, 0]
    out += P[:, 1:2] * M[:3, 1]
    out += P[:, 2:3] * M[:3, 2]
    out += M[:3, 3]
    return out


def _pose_matrices(mesh_obj, arm, names, rest=False, space=None, bind=None):
    """Bone frames in the rig's space (the mesh's object space, or ``space`` (4x4) times it).

    Rest: the bones' rest frames. Pose: each bone's motion as the Armature modifier applies it,
    D = T P R^-1 T^-1 (T: armature -> rig space now, P/R: pose/rest frame in armature space), times
    the rig's rest frame T_bind R (``bind``: the armature -> mesh map at bind time; None = now). So
    moving the mesh object or the armature object later moves the mesh as Blender's modifier would
    (it stayed where it was bound). A pose-bone scale stays in D: the rig's linear blend of the
    skeleton follows it, the thickness does not (making D rigid, each head kept where D puts it,
    measured worse: a parent bone scaled 0.5 stretched edges 7.4x against 2.3x)."""
    S = np.eye(4) if space is None else space
    T = S @ np.array(mesh_obj.matrix_world.inverted() @ arm.matrix_world)  # armature -> rig space now
    T_bind = T if bind is None else S @ bind
    T_inv = _inverse(T)
    out = np.empty((len(names), 4, 4))
    for j, name in enumerate(names):
        bone = arm.data.bones[name]
        R = np.array(bone.matrix_local)
        if rest:
            out[j] = T @ R
        else:
            R_inv = np.array(bone.matrix_local.inverted())
            out[j] = T @ np.array(arm.pose.bones[name].matrix) @ R_inv @ T_inv @ T_bind @ R
    return out


def _rig_space(obj, arm):
    """None when the mesh's object space suits the rig: its transform relative to the armature is a
    similarity, so the bone frames stay rigid in it. Otherwise (non-uniform or negative scale left
    unapplied) the 4x4 map from the mesh's object space to the armature's, in which the rig works:
    bone frames there are rigid, and the mesh keeps its shape as the Armature modifier shows it."""
    A = np.array(arm.matrix_world.inverted() @ obj.matrix_world)
    M = A[:3, :3]
    G = M.T @ M
    s2 = np.trace(G) / 3
    if np.linalg.det(M) > 0 and np.abs(G - s2 * np.eye(3)).max() <= 1e-6 * s2:
        return None
    return A


def _space(info):
    sp = info.get("space")
    return None if sp is None else np.array(sp, dtype=float).reshape(4, 4)


def _encode(arrays):
    # Uncompressed: deflate saved 15% of the text for 9x the time (1.3 s at 655K vertices); files
    # written with it still load (np.load reads both).
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _decode(text):
    with np.load(io.BytesIO(base64.b64decode(text))) as z:
        return {k: z[k] for k in z.files}


def _armature(obj, info):
    """The bound armature: the mesh's armature pointer (Blender points a copy of the mesh duplicated
    with its rig at the copied rig, parented or not) while that armature is in a scene (the pointer
    keeps a deleted armature alive as a user); else by the tag bind put on it: the mesh's parent if
    it carries the tag, else the object of the stored name, else after a rename the one armature
    with the tag and the bound armature data (a copy of the rig carries the tag but has its own
    data). Files bound before the tag: by name only."""
    tag = info.get("armature_tag")
    ptr = obj.get(ARM_PTR)
    if isinstance(ptr, bpy.types.Object) and ptr.type == 'ARMATURE' and ptr.users_scene and (
            tag is None or ptr.get(ARM_TAG) == tag):
        return ptr
    arm = bpy.data.objects.get(info["armature"])
    if arm is not None and arm.type == 'ARMATURE' and not arm.users_scene:
        arm = None  # deleted, kept alive by a pointer
    if tag is None:
        return arm if arm is not None and arm.type == 'ARMATURE' else None
    p = obj.parent
    if p is not None and p.type == 'ARMATURE' and p.users_scene and p.get(ARM_TAG) == tag:
        return p
    if arm is not None and arm.type == 'ARMATURE' and arm.get(ARM_TAG) == tag:
        return arm
    data = info.get("armature_data")
    found = [o for o in bpy.data.objects if o.type == 'ARMATURE' and o.users_scene and o.get(ARM_TAG) == tag
             and (data is None or o.data.name == data)]
    return found[0] if len(found) == 1 else None


def _release_deleted_armature(obj):
    """The armature pointer keeps a deleted armature alive (in no scene): let it go, and free the
    armature once nothing else uses it, so Blender clears the links to it (the mesh's parent, an
    Armature modifier's object) as when deleting an armature nothing points at. Undo restores both."""
    ptr = obj.get(ARM_PTR)
    if not isinstance(ptr, bpy.types.Object) or ptr.users_scene:
        return
    del obj[ARM_PTR]
    if ptr.users == 0:
        bpy.data.objects.remove(ptr)


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


_rest_ok = {}  # (bind id, object name) -> the mesh's vertices are the ones bound (checked once per load)
_buffers = {}  # (bind id, object name) -> (positions (n, 3), float32 (n*3,) output, float32 (n*3,) rest)


def _key(obj, info):
    return (info["id"], obj.name)


def _target(info):
    """HELPER (this version), ATTRIBUTE or SHAPE_KEY (objects bound by earlier versions)."""
    return str(info.get("target", "SHAPE_KEY"))


def _uses_shape_key(info):
    return _target(info) == "SHAPE_KEY"


def _live_modifier(obj, info):
    """The live geometry-nodes modifier: by its stored name, else (renamed) the one whose node group
    reads a helper (the new name is stored); None when it was removed or applied."""
    mod = obj.modifiers.get(str(info.get("modifier", MOD)))
    if mod is not None and mod.type == 'NODES':
        return mod
    for m in obj.modifiers:
        if m.type == 'NODES' and m.node_group is not None and m.node_group.nodes.get(HELPER_NODE) is not None:
            info["modifier"] = m.name
            return m
    return None


def _helper_of(obj, info):
    """The helper object of a HELPER binding: the object the modifier's node group reads (follows
    renames), else by the stored name; None if it is gone."""
    mod = _live_modifier(obj, info)
    ng = mod.node_group if mod is not None else None
    node = ng.nodes.get(HELPER_NODE) if ng is not None else None
    h = node.inputs["Object"].default_value if node is not None else None
    if h is None:
        h = bpy.data.objects.get(str(info.get("helper", "")))
    return h if h is not None and h.type == 'MESH' else None


def _helper_users(helper, exclude=None):
    """Bound objects (other than ``exclude``) whose live modifier reads ``helper``."""
    return [o for o in bpy.data.objects if o is not exclude and is_bound(o) and _target(o[PROP]) == "HELPER"
            and _helper_of(o, o[PROP]) == helper]


def _writes_helper(obj, helper):
    """Whether ``obj`` writes the helper it reads: it is the helper's owner. A duplicate (Shift+D)
    reads the original's helper until it gets its own (``_own_helper``). The owner is claimed by the
    first reader when the recorded one is gone, renamed or no longer reads it."""
    owner = helper.get(OWNER)
    if owner == obj.name:
        return True
    o = bpy.data.objects.get(owner) if isinstance(owner, str) else None
    if o is not None and is_bound(o) and _target(o[PROP]) == "HELPER" and _helper_of(o, o[PROP]) == helper:
        return False
    helper[OWNER] = obj.name
    return True


def _writable(helper, adopt=True):
    """``helper``, or None when its vertices cannot be written. A character linked from a library and
    overridden (Make Library Override) has an override helper whose mesh is still library data,
    which ignores writes: the override takes a local copy once (``adopt``; saved with the file)."""
    if helper.data.library is None:
        return helper
    if not adopt or helper.library is not None or helper.override_library is None:
        return None
    helper.data = helper.data.copy()
    return helper


def _from_library(obj):
    """Why a bound object's binding cannot be changed here (it came with a character linked from a
    library, overridden or not), or None."""
    lib = obj.library or (obj.override_library.reference.library if obj.override_library else None)
    if lib is None:
        return None
    return (f"{obj.name!r} is bound in the library file {bpy.path.basename(lib.filepath)!r}: unbind or rebind it "
            "there (here it deforms live, and Skeletal Bake works)")


def _own_helper(obj, info, shared):
    """A duplicate (Shift+D) reads the original's helper through a copy of its modifier: gives it a
    helper and a node group of its own, as the copy deforms by its own pose (its parent may be the
    copied rig) and in its own place relative to the rig. None if its modifier is not ours."""
    mod = _live_modifier(obj, info)
    ng = mod.node_group if mod is not None else None
    if ng is None or ng.nodes.get(HELPER_NODE) is None:
        return None
    helper = _helper_object(obj, len(shared.data.vertices))
    ng = ng.copy()
    ng.nodes[HELPER_NODE].inputs["Object"].default_value = helper
    mod.node_group = ng
    info["helper"], info["node_group"] = helper.name, ng.name
    return helper


def _replace_helper(obj, info, n):
    """A new helper for one deleted by hand (the Outliner's Blender File view removes it): the
    mesh showed at rest, silently, until unbound. None if the live modifier is not ours."""
    mod = _live_modifier(obj, info)
    ng = mod.node_group if mod is not None else None
    node = ng.nodes.get(HELPER_NODE) if ng is not None else None
    if node is None:
        return None
    old = bpy.data.meshes.get(obj.name + HELPER_SUFFIX)
    if old is not None and old.users == 0:  # the deleted helper's mesh
        bpy.data.meshes.remove(old)
    helper = _helper_object(obj, n)
    node.inputs["Object"].default_value = helper
    info["helper"] = helper.name
    print(f"dgmesh skeletal: the helper object of {obj.name!r} was deleted: made again")
    return helper


def _rest_hash(mesh):
    co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    return hashlib.blake2b(co.tobytes(), digest_size=16).hexdigest()


def _edited(obj, info):
    """The mesh was edited since it was bound: another vertex count, or (checked at load, after
    Edit or Sculpt mode and after undo, as hashing every frame would cost milliseconds) other rest
    positions (moved or reordered vertices). Offsets made for the bound vertices would scramble it."""
    if len(obj.data.vertices) != _rig(obj).n_vertices:
        return True
    key = _key(obj, info)
    if key not in _rest_ok:
        _rest_ok[key] = info.get("rest_hash") in (None, _rest_hash(obj.data))  # None: bound before the hash
    return not _rest_ok[key]


def _follow_renamed_bones(obj, arm, info, names):
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


def _clear_live(obj, info, why, note):
    """Zero offsets (the mesh shows undeformed) for an edited mesh or a deleted armature (``why``),
    once, with a console note."""
    key = _key(obj, info)
    if _last_pose.get(key) == why or _target(info) != "HELPER":
        return
    h = _helper_of(obj, info)
    if h is not None and not _writes_helper(obj, h):
        h = _own_helper(obj, info, h)  # an edited duplicate: the original's offsets are not its own
    if h is not None:
        h = _writable(h)
    if h is None:
        return
    h.data.vertices.foreach_set("co", np.zeros(3 * len(h.data.vertices), dtype=np.float32))
    h.data.update()
    _last_pose[key] = why
    print(f"dgmesh skeletal: {obj.name!r} {note}")


def shown_undeformed(obj):
    """Whether a bound object is shown undeformed because it was edited since bind (the sidebar
    panel says so)."""
    return is_bound(obj) and _last_pose.get(_key(obj, obj[PROP])) == b"edited"


def _new_buffers(obj, rig):
    """Positions (float32: the native deform rounds on output), the float32 array handed to
    foreach_set and the float32 rest positions (the basis: what bind read)."""
    n = rig.n_vertices
    rest = np.empty(3 * n, dtype=np.float32)
    if len(obj.data.vertices) == n:
        obj.data.vertices.foreach_get("co", rest)
    return np.empty((n, 3), dtype=np.float32), np.empty(3 * n, dtype=np.float32), rest


def _deformed(obj, pose):
    """Deforms into the object's reused buffers: (positions (n, 3), float32 (n*3,) ready for
    foreach_set: the positions for a legacy shape key, else the offsets from the rest positions)."""
    info = obj[PROP]
    rig = _rig(obj)
    key = _key(obj, info)
    buf = _buffers.get(key)
    if buf is None or buf[0].shape[0] != rig.n_vertices:
        buf = _buffers[key] = _new_buffers(obj, rig)
    pos, out, rest = buf
    kw = dict(fairing_steps=int(info["fairing_steps"]), method=str(info["method"]).lower(),
              bone_clearance=float(info.get("bone_clearance", 0.95)),  # files bound before the option: 0.95
              # files bound before the option: the linear blend
              dual_quaternion=str(info.get("skeleton_blend", "LINEAR")) == 'DUAL_QUATERNION')
    try:
        rig.deform(pose, out=pos, **kw)
    except (MeshError, TypeError):
        if pos.dtype != np.float32:
            raise
        # A native module without float32 output: deform in float64 from now on.
        pos = np.empty(pos.shape)
        buf = _buffers[key] = (pos, out, rest)
        rig.deform(pose, out=pos, **kw)
    space = _space(info)
    if space is not None:  # rig space -> the mesh's object space
        pos[:] = _transformed(pos, _inverse(space))
    if _uses_shape_key(info):
        np.copyto(out, pos.ravel())
    else:
        np.subtract(pos.ravel(), rest, out=out, casting="same_kind")  # float32 offsets, no temporary
    return buf


def _live_target(obj, info, adopt=True):
    """The foreach_set target of the live update: (collection, property, mesh to tag) of the helper's
    vertices (or a legacy binding's attribute or shape key); Nones when it is missing or when the
    vertex count changed since bind (mesh edited). A duplicate still reading the original's helper
    gets its own first (``adopt``: not while a render evaluates, which must not add objects; it
    shows the original's deformation until then)."""
    none = None, None, None
    n = _rig(obj).n_vertices
    if len(obj.data.vertices) != n:
        return none
    target = _target(info)
    if target == "HELPER":
        h = _helper_of(obj, info)
        if h is None and adopt:
            h = _replace_helper(obj, info, n)
        elif h is not None and not _writes_helper(obj, h):
            h = _own_helper(obj, info, h) if adopt else None
        if h is not None:
            h = _writable(h, adopt)
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
    if _target(info) == "HELPER" and _live_modifier(obj, info) is None:
        # The user removed or applied the live modifier: nothing shows the binding any more, so it
        # goes (helper, skeleton, stored data), as with unbind. The Armature modifiers come back, but
        # disabled when it was applied in a pose (the rest positions changed by the helper's offsets:
        # the mesh holds the pose; at rest the offsets are rounding and the positions barely move).
        if depsgraph is None or depsgraph.mode != 'RENDER':
            h = _helper_of(obj, info)
            co = np.empty(3 * len(obj.data.vertices), dtype=np.float32)
            obj.data.vertices.foreach_get("co", co)
            posed = True
            if h is not None and len(h.data.vertices) and len(co):
                off = np.empty(3 * len(h.data.vertices), dtype=np.float32)
                h.data.vertices.foreach_get("co", off)
                posed = float(np.abs(off).max()) > 1e-5 * float(np.ptp(co.reshape(-1, 3), axis=0).max())
            applied = len(obj.data.vertices) != _rig(obj).n_vertices or (posed and _rest_hash(obj.data) != info.get(
                "rest_hash", _rest_hash(obj.data)))
            unbind(obj, enable_armature=not applied)
            _purge_orphans()
            print(f"dgmesh skeletal: the live modifier of {obj.name!r} was "
                  + ("applied: unbound (its Armature modifiers are back, disabled)" if applied else "removed: unbound"))
        return False
    arm = _armature(obj, info)
    if arm is None:
        _clear_live(obj, info, b"no armature", "its armature is gone: shown at rest (Skeletal Unbind restores "
                    "its modifiers)")
        if depsgraph is None or depsgraph.mode != 'RENDER':
            _release_deleted_armature(obj)
        return False
    names = list(info["bones"])
    if any(n not in arm.pose.bones for n in names) and (depsgraph is None or depsgraph.mode != 'RENDER'):
        names = _follow_renamed_bones(obj, arm, info, names)
    missing = [n for n in names if n not in arm.pose.bones]
    if missing:
        _clear_live(obj, info, b"bones", f"has bones missing from {arm.name!r} ({', '.join(missing[:4])}): shown "
                    "at rest; name them back, or Skeletal Rebind")
        return False
    if _edited(obj, info):
        _clear_live(obj, info, b"edited", "was edited since it was bound (vertex count or positions): shown "
                    "undeformed; Skeletal Rebind binds it again")
        return False
    space = _space(info)
    bind = info.get("bind_to_mesh")
    bind = None if bind is None else np.array(bind, dtype=float).reshape(4, 4)
    if depsgraph is not None:
        pose = _pose_matrices(obj.evaluated_get(depsgraph), arm.evaluated_get(depsgraph), names, space=space,
                              bind=bind)
    else:
        pose = _pose_matrices(obj, arm, names, space=space, bind=bind)
    sig = pose.tobytes()
    # Same pose: nothing to write, unless the helper was deleted by hand (_live_target makes it
    # again, with this pose's offsets).
    if not force and _last_pose.get(_key(obj, info)) == sig and (
            _target(info) != "HELPER" or _helper_of(obj, info) is not None):
        return False
    data, prop, tagged = _live_target(obj, info, adopt=depsgraph is None or depsgraph.mode != 'RENDER')
    if data is None:
        return False
    _, co, _ = _deformed(obj, pose)
    data.foreach_set(prop, co)
    tagged.update()
    _last_pose[_key(obj, info)] = sig
    return True


@bpy.app.handlers.persistent
def _on_update(scene, depsgraph=None):
    global _updating
    if _updating:
        return
    _updating = True
    try:
        wrote = False
        # The bound objects first: an update may unbind one (its live modifier removed), removing its
        # helper and skeleton objects, and removing objects while iterating scene.objects crashes 4.x.
        for obj in [o for o in scene.objects if is_bound(o)]:
            # In Edit mode the edit-mesh owns the data (attribute arrays are empty): wait for Object
            # mode. Edit and Sculpt mode may move or reorder the vertices (Sort Elements): check the
            # rest positions again when the object is back.
            if obj.mode in ('EDIT', 'SCULPT'):
                _rest_ok.pop(_key(obj, obj[PROP]), None)
            else:
                try:
                    wrote |= update_object(obj, depsgraph=depsgraph)
                except Exception as exc:  # a handler must never take Blender down
                    print(f"dgmesh skeletal: update of {obj.name!r} failed: {exc}")
        # A render's depsgraph has evaluated this frame before the handler wrote the offsets, and
        # nothing evaluates it again before the frame is drawn (the view layer's does, after
        # frame_set): re-evaluate what the write changed.
        if wrote and depsgraph is not None and depsgraph.mode == 'RENDER':
            depsgraph.update()
    finally:
        _updating = False


@bpy.app.handlers.persistent
def _on_load(*_args):
    _purge_orphans()
    for o in bpy.data.objects:  # helpers of files bound before they were disabled in viewports
        if OWNER in o.keys() and not o.hide_viewport and o.library is None:
            o.hide_viewport = True
    # Overridden characters saved before any update gave their helper a local mesh: now, before a
    # render (`blender -b shot.blend -a`), whose handler calls may not add data.
    for o in bpy.data.objects:
        if o.override_library is not None and is_bound(o) and _target(o[PROP]) == "HELPER":
            h = _helper_of(o, o[PROP])
            if h is not None:
                _writable(h)
    _rest_ok.clear()
    _rigs.clear()
    _last_pose.clear()
    _buffers.clear()


@bpy.app.handlers.persistent
def _on_undo(*_args):
    # Undo restores the pose and the attribute from one snapshot, but not our cache of the last
    # pose: forget it so the next update recomputes instead of trusting a stale signature. It may
    # also undo an edit of a bound mesh: check the rest positions again.
    _last_pose.clear()
    _rest_ok.clear()


_HANDLERS = (("depsgraph_update_post", _on_update), ("frame_change_post", _on_update),
             ("load_post", _on_load), ("undo_post", _on_undo), ("redo_post", _on_undo))


def _set_position_group():
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


def _enabled(sockets, name, kind='VECTOR'):
    """The socket of that name and type: 3.x nodes have one per data type, only the chosen enabled."""
    return next(s for s in sockets if s.name == name and s.type == kind and getattr(s, "enabled", True))


def _helper_node_group(helper):
    """Set Position (Offset = Sample Index(Object Info(helper, Original).Geometry, Position, Index)),
    on all points only when the geometry has as many points as the helper: moved below a modifier
    that changes the vertices (a Subdivision Surface), the offsets would scramble the mesh (Blender's
    Armature modifier keeps working there; ours shows the mesh undeformed and the panel says why)."""
    ng, sp = _set_position_group()
    nodes = ng.nodes
    oi = nodes.new('GeometryNodeObjectInfo')
    oi.name = HELPER_NODE
    oi.transform_space = 'ORIGINAL'  # the helper's own coordinates: offsets in the mesh's object space
    oi.inputs["Object"].default_value = helper
    si = nodes.new('GeometryNodeSampleIndex')
    si.data_type, si.domain = 'FLOAT_VECTOR', 'POINT'
    pos, idx = nodes.new('GeometryNodeInputPosition'), nodes.new('GeometryNodeInputIndex')
    ng.links.new(oi.outputs["Geometry"], si.inputs["Geometry"])
    ng.links.new(pos.outputs[0], _enabled(si.inputs, "Value"))
    ng.links.new(idx.outputs[0], si.inputs["Index"])
    ng.links.new(_enabled(si.outputs, "Value"), sp.inputs["Offset"])
    gi = next(n for n in nodes if n.type == 'GROUP_INPUT')
    size_in, size_helper = nodes.new('GeometryNodeAttributeDomainSize'), nodes.new('GeometryNodeAttributeDomainSize')
    same = nodes.new('FunctionNodeCompare')
    same.data_type, same.operation = 'INT', 'EQUAL'
    ng.links.new(gi.outputs[0], size_in.inputs["Geometry"])
    ng.links.new(oi.outputs["Geometry"], size_helper.inputs["Geometry"])
    ng.links.new(size_in.outputs["Point Count"], _enabled(same.inputs, "A", 'INT'))
    ng.links.new(size_helper.outputs["Point Count"], _enabled(same.inputs, "B", 'INT'))
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
    if not is_bound(obj) or _target(obj[PROP]) != "HELPER":
        return False
    mod = _live_modifier(obj, obj[PROP])
    if mod is None:
        return False
    shown = [m for m in obj.modifiers if m.show_viewport or m == mod]
    return shown[0] != mod


def _remove_object(o):
    me = o.data
    bpy.data.objects.remove(o)
    if me is not None and me.users == 0:
        bpy.data.meshes.remove(me)


def _purge_orphans():
    """The hidden helper and skeleton objects of a bound mesh that was deleted (hidden and
    unselectable, the user cannot find them to delete them); run at load, bind and unbind."""
    for h in [o for o in bpy.data.objects if OWNER in o.keys()]:
        if not _helper_users(h):
            _remove_object(h)
    for sk in [o for o in bpy.data.objects if SKELETON_OF in o.keys()]:
        if sk.parent is None or not is_bound(sk.parent):
            _remove_object(sk)


def _hide_everywhere(o):
    """Hides an internal object in every view layer that holds it (hide_set acts on one view layer
    only; a scene sharing the mesh showed the skeleton), never raising for a view layer that
    excludes its collection."""
    for scene in bpy.data.scenes:
        if o.name not in scene.objects:
            continue
        for layer in scene.view_layers:
            for attempt in range(2):
                try:
                    o.hide_set(True, view_layer=layer)
                    break
                except RuntimeError:  # a view layer not yet synced with the new object, or excluding it
                    if attempt == 0:
                        layer.update()


def _helper_object(obj, n):
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
    _hide_everywhere(h)
    # Disabled in viewports too: a collection instance ignores the view-layer hide and drew it (a
    # modifier's dependency is still evaluated).
    h.hide_viewport = True
    h.hide_render = True
    h.hide_select = True
    h.display_type = 'BOUNDS'
    h[OWNER] = obj.name
    return h


def _offset_node_group():
    """Objects bound by the previous version: Set Position (Offset = Named Attribute ATTR)."""
    ng, sp = _set_position_group()
    nodes = ng.nodes
    na = nodes.new('GeometryNodeInputNamedAttribute')
    na.data_type = 'FLOAT_VECTOR'
    na.inputs["Name"].default_value = ATTR
    # 3.x has one "Attribute" output per data type (only the chosen one enabled), 4.x one output.
    out = next(s for s in na.outputs if s.type == 'VECTOR' and getattr(s, "enabled", True))
    ng.links.new(out, sp.inputs["Offset"])
    na.location = (-400, -150)
    return ng


def _move_first(obj, mod):
    """Puts a modifier first in the stack (shape keys apply before any modifier, so should we)."""
    compat.move_modifier(obj, mod, 0)


def _skeleton_object(context, obj, rig, space=None):
    """Hidden mesh object with the skeletal mesh and its radius colouring (fig. 6.8)."""
    name = obj.name + "_skeleton"
    me = bpy.data.meshes.new(name)
    S = rig.skeleton_vertices
    if space is not None:  # rig space -> the mesh's object space (the skeleton is parented to it)
        S = _transformed(S, _inverse(space))
    me.from_pydata([tuple(p) for p in S], [], [tuple(int(i) for i in f) for f in rig.control_faces])
    me.update()
    rgba = colors.sequential(rig.radii)
    bridge.write_point_float(me, "dg_radius", rig.radii)
    bridge.write_point_color(me, "dg_radius_color", rgba)
    sk = bpy.data.objects.new(name, me)
    for coll in editable_collections(obj) or [context.scene.collection]:
        coll.objects.link(sk)
    sk.parent = obj
    sk[SKELETON_OF] = obj.name
    _hide_everywhere(sk)  # (a collection excluded from the view layer: hide_set raised mid-bind)
    sk.hide_viewport = True  # also in collection instances; DG Mesh > Show Skeleton reveals it
    sk.hide_render = True
    return sk


def skeleton_of(obj):
    """The skeleton object of a bound mesh (None when it was deleted)."""
    if not is_bound(obj):
        return None
    sk = bpy.data.objects.get(obj[PROP].get("skeleton", ""))
    if sk is not None and sk.get(SKELETON_OF) is not None:
        return sk
    # Renamed: it is parented to its mesh.
    return next((c for c in obj.children if c.get(SKELETON_OF) is not None), None)


class DGMESH_OT_skeletal_show_skeleton(bpy.types.Operator):
    """Show or hide the skeletal mesh of the active bound object, coloured by medial-ball radius \
(thesis fig. 6.8)"""

    bl_idname = "dgmesh.skeletal_show_skeleton"
    bl_label = "Show Skeleton"
    bl_options = {'REGISTER', 'UNDO'}

    show: bpy.props.BoolProperty(name="Show", default=True)

    @classmethod
    def poll(cls, context):
        if skeleton_of(context.active_object) is None:
            return _poll_fail(cls, "The active object is not bound, or its skeleton was deleted")
        return True

    def execute(self, context):
        sk = skeleton_of(context.active_object)
        sk.hide_viewport = not self.show
        try:
            sk.hide_set(not self.show)
        except RuntimeError:  # not in this view layer
            pass
        return {'FINISHED'}


class DGMESH_OT_skeletal_bind(bpy.types.Operator):
    """Bind the active mesh to the selected armature's deform bones: posing then keeps the \
mesh's thickness (no collapsing joints or candy wrappers)"""

    bl_idname = "dgmesh.skeletal_bind"
    bl_label = "Skeletal Bind"
    bl_options = {'REGISTER', 'UNDO'}

    control_faces: IntProperty(name="Control Faces", default=BIND_DEFAULTS.control_faces, min=200, max=200000,
                               description="Meshes with more faces are deformed through a decimated control "
                               "mesh of about this many faces (multiresolution)")
    fairing_steps: IntProperty(name="Fairing Steps", default=DEFORM_DEFAULTS.fairing_steps, min=0, max=20,
                               description="Shape-preserving self-intersection fairing steps per pose (eq. 6.15)")
    method: EnumProperty(name="Method", items=METHODS, default=enum_id(DEFORM_DEFAULTS.method))
    bone_clearance: FloatProperty(name="Bone Clearance", default=DEFORM_DEFAULTS.bone_clearance, min=0.0, max=1.0,
                                  description="Keep each vertex at least this fraction of its rest distance from "
                                  "the bones it follows (a joint's inner crease); 0 = off, 1 = every rest distance "
                                  "(costs thickness under twists)")
    skeleton_blend: EnumProperty(
        name="Skeleton Blend", items=SKELETON_BLENDS,
        default='DUAL_QUATERNION' if DEFORM_DEFAULTS.dual_quaternion else 'LINEAR',
        description="How the bone motions are blended on the skeletal mesh where a vertex follows several bones")

    @classmethod
    def register(cls):
        set_handlers(_HANDLERS)

    @classmethod
    def unregister(cls):
        set_handlers(_HANDLERS, add=False)

    @classmethod
    def poll(cls, context):
        if context.mode != 'OBJECT':
            return _poll_fail(cls, "Only available in Object mode")
        if _bind_target(context) is None:
            return _poll_fail(cls, "Select the mesh and its armature (the mesh active, or the armature with "
                                   "one mesh selected)")
        return True

    def execute(self, context):
        obj = _bind_target(context)
        if is_bound(obj):
            self.report({'ERROR'}, f"{obj.name!r} is already bound; unbind it first (DG Mesh > Skeletal Unbind)")
            return {'CANCELLED'}
        reason = read_only_reason(obj)
        if reason:
            self.report({'ERROR'}, f"Cannot bind {obj.name!r}: its {reason} (bind it in its own file)")
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
        if ATTR in obj.data.attributes or MOD in obj.modifiers:
            self.report({'ERROR'}, f"{obj.name!r} already has an attribute {ATTR!r} or a modifier {MOD!r} "
                        "(left from an earlier binding?); remove them first")
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
        for o in (obj, arm):
            if abs(o.matrix_world.determinant()) < 1e-12:
                self.report({'ERROR'}, f"{o.name!r} has zero scale (its transform cannot be inverted); give it a "
                            "non-zero scale first")
                return {'CANCELLED'}
        space = _rig_space(obj, arm)
        rest = _pose_matrices(obj, arm, names, rest=True, space=space)
        to_mesh = obj.matrix_world.inverted() @ arm.matrix_world
        heads = np.array([tuple(to_mesh @ arm.data.bones[n].head_local) for n in names])
        tails = np.array([tuple(to_mesh @ arm.data.bones[n].tail_local) for n in names])
        if space is not None:
            V, heads, tails = (_transformed(P, space) for P in (V, heads, tails))
            if np.linalg.det(space[:3, :3]) < 0:  # a mirror turns the surface inside out: re-orient
                F = F[:, ::-1].copy()
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
            if "open" in msg or "boundary" in msg:
                if any(m.type == 'MIRROR' for m in obj.modifiers):
                    msg += (" (the Mirror modifier closes it only in the evaluated mesh: apply the modifier "
                            "before binding)")
                else:
                    msg += " (unmerged vertices along a seam? Mesh > Clean Up > Merge by Distance)"
            self.report({'ERROR'}, msg)
            return {'CANCELLED'}
        finally:
            if has_window:
                wm.progress_end()
        bid = uuid.uuid4().hex
        # What the binding adds comes first and goes again if anything fails, before the user's
        # Armature modifiers are touched: a failure leaves the object as it was.
        helper = ng = mod = sk = None
        try:
            helper = _helper_object(obj, len(V))
            ng = _helper_node_group(helper)
            mod = obj.modifiers.new(MOD, 'NODES')
            mod.node_group = ng
            _move_first(obj, mod)
            sk = _skeleton_object(context, obj, rig, space)
        except Exception as exc:
            if mod is not None:
                obj.modifiers.remove(mod)
            if ng is not None and ng.users == 0:
                bpy.data.node_groups.remove(ng)
            for o in (sk, helper):
                if o is not None:
                    me = o.data
                    bpy.data.objects.remove(o)
                    if me.users == 0:
                        bpy.data.meshes.remove(me)
            self.report({'ERROR'}, f"Skeletal Bind failed on {obj.name!r}: {type(exc).__name__}: {exc}")
            return {'CANCELLED'}
        tag = arm.get(ARM_TAG)
        if not isinstance(tag, str):
            tag = arm[ARM_TAG] = uuid.uuid4().hex
        disabled = []
        for m in obj.modifiers:
            if m.type == 'ARMATURE' and (m.show_viewport or m.show_render):
                disabled.append([m.name, int(m.show_viewport), int(m.show_render),
                                 m.object.name if m.object is not None else ""])
                m.object = None
                m.show_viewport = False
                m.show_render = False
        obj[PROP] = {
            "id": bid, "armature": arm.name, "armature_tag": tag, "armature_data": arm.data.name,
            "bind_to_mesh": [float(x) for x in np.array(obj.matrix_world.inverted() @ arm.matrix_world).ravel()],
            "bones": names, "data": _encode(rig.to_arrays()),
            "bones_local": [float(x) for n in names for x in np.array(arm.data.bones[n].matrix_local).ravel()],
            "fairing_steps": self.fairing_steps, "method": self.method, "bone_clearance": self.bone_clearance,
            "skeleton_blend": self.skeleton_blend,
            "control_faces": self.control_faces, "target": "HELPER",
            "modifier": mod.name, "node_group": ng.name, "helper": helper.name,
            "modifiers": [m[0] for m in disabled], "modifiers_viewport": [m[1] for m in disabled],
            "modifiers_render": [m[2] for m in disabled], "modifiers_object": [m[3] for m in disabled],
            "skeleton": sk.name, "rest_hash": _rest_hash(obj.data),
        }
        if space is not None:
            obj[PROP]["space"] = [float(x) for x in space.ravel()]
        obj[ARM_PTR] = arm
        _rigs[bid] = rig
        _purge_orphans()
        update_object(obj, force=True)
        others = [o.name for o in context.selected_objects if o.type == 'MESH' and o != obj]
        self.report({'INFO'}, f"Bound {obj.name!r} ({len(V)} vertices, control mesh {rig.n_control} vertices) to "
                    f"{len(names)} deform bones of {arm.name!r}" + ("" if W is not None else
                                                                  " with distance weights (no vertex groups)")
                    + (f"; only the active mesh is bound: bind {', '.join(map(repr, others[:3]))} one at a time"
                       if others else ""))
        return {'FINISHED'}


def unbind(obj, enable_armature=True):
    """Removes the binding and restores the Armature modifiers bind disabled (left disabled with
    ``enable_armature`` False: the mesh already holds a pose)."""
    info = obj[PROP].to_dict()  # a copy: the ID property is deleted below
    _last_pose.pop(_key(obj, info), None)
    _buffers.pop(_key(obj, info), None)
    if _uses_shape_key(info):  # bound by an earlier version
        keys = obj.data.shape_keys
        if keys and KEY in keys.key_blocks:
            obj.shape_key_remove(keys.key_blocks[KEY])
        keys = obj.data.shape_keys
        if info.get("created_basis") and keys and len(keys.key_blocks) == 1:
            obj.shape_key_remove(keys.key_blocks[0])
    else:
        helper = _helper_of(obj, info) if _target(info) == "HELPER" else None
        mod = _live_modifier(obj, info)
        ng = mod.node_group if mod is not None else None
        if mod is not None:
            obj.modifiers.remove(mod)
        if _target(info) == "ATTRIBUTE":
            att = obj.data.attributes.get(ATTR)
            if att is not None:
                obj.data.attributes.remove(att)
        if ng is None:
            ng = bpy.data.node_groups.get(str(info["node_group"]))
        if ng is not None and ng.users == 0:
            bpy.data.node_groups.remove(ng)
        # The helper goes with the last object reading it (a duplicate may still read it).
        if helper is not None and not _helper_users(helper, exclude=obj):
            me = helper.data
            bpy.data.objects.remove(helper)
            if me.users == 0:
                bpy.data.meshes.remove(me)
    objects = info.get("modifiers_object", [None] * len(info["modifiers"]))
    arm = _armature(obj, info)  # renamed since bind: found by its tag
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
    if not any(is_bound(o) and o[PROP]["id"] == info["id"] for o in bpy.data.objects):
        _rigs.pop(info["id"], None)  # no duplicate left using this bind data


class DGMESH_OT_skeletal_rebind(bpy.types.Operator):
    """Bind the active mesh again to its armature with the same settings: after editing the mesh or \
painting its weights (the binding keeps what it read at bind)"""

    bl_idname = "dgmesh.skeletal_rebind"
    bl_label = "Skeletal Rebind"
    bl_options = {'REGISTER', 'UNDO'}

    object_name: StringProperty(name="Object", default="", options={'HIDDEN', 'SKIP_SAVE'},
                                description="The bound object (empty: the active object)")

    @classmethod
    def poll(cls, context):
        if context.mode != 'OBJECT':
            return _poll_fail(cls, "Only available in Object mode")
        if not any(is_bound(o) for o in context.scene.objects):  # the sidebar names a bound object
            return _poll_fail(cls, "Nothing to rebind: the meshes in this scene are not bound "
                                   "(DG Mesh > Skeletal Bind)")
        return True

    def execute(self, context):
        obj = bpy.data.objects.get(self.object_name) if self.object_name else context.active_object
        if obj is None or not is_bound(obj):
            who = repr(self.object_name) if self.object_name else "The active object"
            self.report({'ERROR'}, f"{who} is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        reason = _from_library(obj)
        if reason:
            self.report({'ERROR'}, reason)
            return {'CANCELLED'}
        info = obj[PROP]
        arm = _armature(obj, info)
        if arm is None:
            self.report({'ERROR'}, f"The armature {str(info['armature'])!r} of {obj.name!r} is gone: select an "
                        "armature and use Skeletal Unbind, then Skeletal Bind")
            return {'CANCELLED'}
        settings = dict(fairing_steps=int(info["fairing_steps"]), method=str(info["method"]),
                        bone_clearance=float(info.get("bone_clearance", 0.95)),
                        skeleton_blend=str(info.get("skeleton_blend", "LINEAR")),
                        control_faces=int(info.get("control_faces", 5000)))
        unbind(obj)
        with context.temp_override(selected_objects=[obj, arm], active_object=obj, object=obj):
            try:
                bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT', **settings)
            except RuntimeError as exc:  # the bind's own report, e.g. the edit opened the mesh
                self.report({'ERROR'}, f"{obj.name!r} is unbound now; binding it again failed: "
                            + str(exc).replace("Error: ", "").strip())
                return {'CANCELLED'}
        self.report({'INFO'}, f"Rebound {obj.name!r} to {arm.name!r}")
        return {'FINISHED'}


class DGMESH_OT_skeletal_unbind(bpy.types.Operator):
    """Remove the skeletal binding: the live modifier and its hidden helper object, the skeleton \
object and the stored data; the Armature modifiers are restored"""

    bl_idname = "dgmesh.skeletal_unbind"
    bl_label = "Skeletal Unbind"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_bound(cls, context)

    def execute(self, context):
        obj = context.active_object
        if not is_bound(obj):
            self.report({'ERROR'}, "The active object is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        reason = _from_library(obj)
        if reason:
            self.report({'ERROR'}, reason)
            return {'CANCELLED'}
        unbind(obj)
        _purge_orphans()
        self.report({'INFO'}, f"Unbound {obj.name!r}")
        return {'FINISHED'}


def write_pc2(path, frames, start, rate=1.0):
    """Writes (nframes, n, 3) positions as a PC2 point cache."""
    frames = np.ascontiguousarray(frames, dtype=np.float32)
    with open(path, "wb") as f:
        f.write(struct.pack("<12siiffi", b"POINTCACHE2\0", 1, frames.shape[1], float(start), float(rate),
                            frames.shape[0]))
        f.write(frames.tobytes())


def _default_cache_path(obj):
    """//<blend>_<object>_skeletal.pc2: the .blend's name too, or two files in one folder baking a
    character of the same name overwrote each other's cache."""
    stem = bpy.path.clean_name(bpy.path.display_name_from_filepath(bpy.data.filepath)) if bpy.data.filepath else ""
    return f"//{stem + '_' if stem else ''}{bpy.path.clean_name(obj.name)}_skeletal.pc2"


class DGMESH_OT_skeletal_bake(bpy.types.Operator):
    """Bake the skeletal deformation of a frame range to a .pc2 point cache played by a Mesh \
Cache modifier (renders and exports then need no add-on)"""

    bl_idname = "dgmesh.skeletal_bake"
    bl_label = "Skeletal Bake"
    bl_options = {'REGISTER', 'UNDO'}

    filepath: StringProperty(name="File", subtype='FILE_PATH', default="", options=compat.FILE_PATH_OPTIONS,
                             description="The .pc2 file; empty: //<file>_<object>_skeletal.pc2 next to the .blend "
                             "(named after both, so two shots of one character in a folder keep their caches)")
    frame_start: IntProperty(name="Start", default=1, description="First frame (default: the scene's)")
    frame_end: IntProperty(name="End", default=250, description="Last frame (default: the scene's)")

    filter_glob: StringProperty(default="*.pc2", options={'HIDDEN'})

    @classmethod
    def poll(cls, context):
        return _poll_bound(cls, context)

    def invoke(self, context, event):
        # An unsaved file has no folder for the default '//' path: ask where the cache goes.
        if not bpy.data.filepath and (not self.filepath or self.filepath.startswith("//")):
            self.filepath = f"{bpy.path.clean_name(context.active_object.name)}_skeletal.pc2"
            context.window_manager.fileselect_add(self)
            return {'RUNNING_MODAL'}
        return self.execute(context)

    def execute(self, context):
        obj = context.active_object
        if not is_bound(obj):
            self.report({'ERROR'}, "The active object is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        # Unset options follow the scene and the object (two bound objects must not share a cache).
        if not self.properties.is_property_set("frame_start"):
            self.frame_start = context.scene.frame_start
        if not self.properties.is_property_set("frame_end"):
            self.frame_end = context.scene.frame_end
        if not self.filepath:
            self.filepath = _default_cache_path(obj)
        if self.frame_end < self.frame_start:
            self.report({'ERROR'}, f"Frame range {self.frame_start}..{self.frame_end} is empty")
            return {'CANCELLED'}
        path = bpy.path.abspath(self.filepath)
        if self.filepath.startswith("//") and not bpy.data.filepath:
            self.report({'ERROR'}, "Save the .blend first or give an absolute path for the cache")
            return {'CANCELLED'}
        info = obj[PROP]
        if _armature(obj, info) is None:
            self.report({'ERROR'}, f"The armature {obj.name!r} was bound to ({info['armature']!r} at bind time) is "
                        "gone")
            return {'CANCELLED'}
        if _edited(obj, info):
            self.report({'ERROR'}, f"{obj.name!r} was edited since it was bound (vertex count or positions): "
                        "unbind and bind it again before baking")
            return {'CANCELLED'}
        scene = context.scene
        current = scene.frame_current
        frames = []
        wm = context.window_manager
        has_window = context.window is not None
        # Each frame is sampled as the stack evaluates it up to where the cache goes (_cache_index:
        # the basis, shape keys, the live offsets and any modifier before the Armature modifiers),
        # with the modifiers after it (and an earlier cache) muted: the cache then replaces exactly
        # that part of the stack.
        live = _live_modifier(obj, info)
        cut = _cache_index(obj, live)
        others = [m for m in obj.modifiers if m.name != CACHE]
        muted = [m for m in obj.modifiers if m.show_viewport and (m.name == CACHE or others.index(m) >= cut)]
        for m in muted:
            m.show_viewport = False
        if has_window:
            wm.progress_begin(self.frame_start, self.frame_end)
        try:
            for fr in range(self.frame_start, self.frame_end + 1):
                scene.frame_set(fr)  # the live handler deforms this frame's pose
                frames.append(_evaluated_positions(obj, context.evaluated_depsgraph_get()))
                if has_window:
                    wm.progress_update(fr)
        finally:
            for m in muted:
                m.show_viewport = True
            scene.frame_set(current)
            if has_window:
                wm.progress_end()
        if any(len(f) != len(obj.data.vertices) for f in frames):
            self.report({'ERROR'}, "The live deformation changed the vertex count: nothing baked")
            return {'CANCELLED'}
        try:
            write_pc2(path, np.array(frames), self.frame_start)
        except OSError as exc:
            self.report({'ERROR'}, f"Cannot write {path}: {exc}")
            return {'CANCELLED'}
        mod = obj.modifiers.get(CACHE) or obj.modifiers.new(CACHE, 'MESH_CACHE')
        # Off while it moves into place (Blender 3.4 moves through an operator, which evaluates
        # the stack: at the end, after a Subdivision, the cache reads a vertex count mismatch).
        shown = mod.show_viewport, mod.show_render
        mod.show_viewport = mod.show_render = False
        compat.move_modifier(obj, mod, cut)
        mod.cache_format = 'PC2'
        mod.deform_mode = 'OVERWRITE'
        mod.filepath = self.filepath
        mod.frame_start = self.frame_start
        mod.show_viewport, mod.show_render = shown
        self.report({'INFO'}, f"Baked {plural(len(frames), 'frame')} of {obj.name!r} to {path}")
        return {'FINISHED'}


def _evaluated_positions(obj, depsgraph):
    ev = obj.evaluated_get(depsgraph)
    me = ev.data  # the evaluated mesh itself: to_mesh() copied it (0.18 s a frame at 655K vertices)
    if isinstance(me, bpy.types.Mesh) and len(me.vertices) == len(obj.data.vertices):
        co = np.empty(3 * len(me.vertices), dtype=np.float32)
        me.vertices.foreach_get("co", co)
        return co.reshape(-1, 3)
    me = ev.to_mesh()
    try:
        co = np.empty(3 * len(me.vertices), dtype=np.float32)
        me.vertices.foreach_get("co", co)
        return co.reshape(-1, 3)
    finally:
        ev.to_mesh_clear()


def _cache_index(obj, live):
    """Where the baked Mesh Cache (overwrite) goes in the stack without it: right after the live
    modifier and the Armature modifiers (restored by unbind, they deform before it and are
    overwritten), before every other modifier after them (a Subdivision Surface or a Smooth then
    works on the cached positions, whose vertex count is the mesh's)."""
    others = [m for m in obj.modifiers if m.name != CACHE]
    after = [i for i, m in enumerate(others) if m == live or m.type == 'ARMATURE']
    return max(after) + 1 if after else 0


classes = (DGMESH_OT_skeletal_bind, DGMESH_OT_skeletal_rebind, DGMESH_OT_skeletal_unbind, DGMESH_OT_skeletal_bake,
           DGMESH_OT_skeletal_show_skeleton)
