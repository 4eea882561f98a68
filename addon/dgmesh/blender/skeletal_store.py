"""Where a skeletal binding lives in the .blend and how its parts are found again: the custom
property holding the bind data (and the rig rebuilt from it), the names and pointers of what bind
adds (live modifier, helper and skeleton objects, the armature's tag), the bound armature (followed
through renames and duplication) and the removal of internal objects whose mesh is gone."""

import hashlib

import bpy
import numpy as np

from .. import colors
from ..skeletal import SkeletalRig
from ..skeletal_data import decode_arrays
from . import bridge
from .common import editable_collections
from .skeletal_space import inverse, transformed

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

rigs = {}          # bind id -> SkeletalRig (rebuilt from the stored data after a reload)


def bound_armature(obj, info):
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


def release_deleted_armature(obj):
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
    """Whether ``obj`` is a mesh object holding a binding (Skeletal Bind's custom property)."""
    return obj is not None and obj.type == 'MESH' and PROP in obj.keys()


def bound_rig(obj):
    """The SkeletalRig of a bound object, rebuilt from its stored data once per bind id (``rigs``)."""
    info = obj[PROP]
    bid = info["id"]
    rig = rigs.get(bid)
    if rig is None:
        rig = SkeletalRig.from_arrays(decode_arrays(info["data"]))
        rigs[bid] = rig
    return rig


def state_key(obj, info):
    """Key of per-object live state: (bind id, object name); a duplicate shares the bind id."""
    return (info["id"], obj.name)


def target_of(info):
    """HELPER (this version), ATTRIBUTE or SHAPE_KEY (objects bound by earlier versions)."""
    return str(info.get("target", "SHAPE_KEY"))


def uses_shape_key(info):
    """Whether a binding (of an earlier version) writes the shape key ``KEY``."""
    return target_of(info) == "SHAPE_KEY"


def live_modifier(obj, info):
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


def helper_of(obj, info):
    """The helper object of a HELPER binding: the object the modifier's node group reads (follows
    renames), else by the stored name; None if it is gone."""
    mod = live_modifier(obj, info)
    ng = mod.node_group if mod is not None else None
    node = ng.nodes.get(HELPER_NODE) if ng is not None else None
    h = node.inputs["Object"].default_value if node is not None else None
    if h is None:
        h = bpy.data.objects.get(str(info.get("helper", "")))
    return h if h is not None and h.type == 'MESH' else None


def helper_users(helper, exclude=None):
    """Bound objects (other than ``exclude``) whose live modifier reads ``helper``."""
    return [o for o in bpy.data.objects if o is not exclude and is_bound(o) and target_of(o[PROP]) == "HELPER"
            and helper_of(o, o[PROP]) == helper]


def from_library(obj):
    """Why a bound object's binding cannot be changed here (it came with a character linked from a
    library, overridden or not), or None."""
    lib = obj.library or (obj.override_library.reference.library if obj.override_library else None)
    if lib is None:
        return None
    return (f"{obj.name!r} is bound in the library file {bpy.path.basename(lib.filepath)!r}: unbind or rebind it "
            "there (here it deforms live, and Skeletal Bake works)")


def rest_hash(mesh):
    """Hash of a mesh's vertex positions (bind stores it; a change means the mesh was edited)."""
    co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    return hashlib.blake2b(co.tobytes(), digest_size=16).hexdigest()


def remove_object(o):
    """Removes an object, and its mesh when nothing else uses it."""
    me = o.data
    bpy.data.objects.remove(o)
    if me is not None and me.users == 0:
        bpy.data.meshes.remove(me)


def purge_orphans():
    """The hidden helper and skeleton objects of a bound mesh that was deleted (hidden and
    unselectable, the user cannot find them to delete them); run at load, bind and unbind."""
    for h in [o for o in bpy.data.objects if OWNER in o.keys()]:
        if not helper_users(h):
            remove_object(h)
    for sk in [o for o in bpy.data.objects if SKELETON_OF in o.keys()]:
        if sk.parent is None or not is_bound(sk.parent):
            remove_object(sk)


def hide_everywhere(o):
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


def skeleton_object(context, obj, rig, space=None):
    """Hidden mesh object with the skeletal mesh and its radius colouring (fig. 6.8)."""
    name = obj.name + "_skeleton"
    me = bpy.data.meshes.new(name)
    S = rig.skeleton_vertices
    if space is not None:  # rig space -> the mesh's object space (the skeleton is parented to it)
        S = transformed(S, inverse(space))
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
    hide_everywhere(sk)  # (a collection excluded from the view layer: hide_set raised mid-bind)
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
