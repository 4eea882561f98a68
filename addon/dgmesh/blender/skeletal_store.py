"""Where a skeletal binding lives in the .blend and how its parts are found again: the custom
property holding the bind data (and the rig rebuilt from it), the names and pointers of what bind
adds (live modifier, helper and skeleton objects, the armature's tag), the bound armature (followed
through renames and duplication) and the removal of internal objects whose mesh is gone.

The property shows in the Custom Properties panel, so a user may edit it: operators check it first
(``bind_problem``: its fields against skeletal_data's versioned schema, then its bind data) and
report what is wrong; Skeletal Unbind always removes it (``salvaged``)."""

import hashlib

import bpy
import numpy as np

from .. import colors
from ..core import MeshError
from ..skeletal import METHODS, SkeletalRig
from ..skeletal_data import INFO_FIELDS, BindDataError, check_arrays, check_info, decode_arrays
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
SKELETON_NODE = "dg_skeleton"   # an unlinked Object Info node: makes the mesh depend on the skeleton object
MOD = "dg_skeletal"             # geometry-nodes modifier adding the offsets to the positions
CACHE = "dg_skeletal_cache"     # the Mesh Cache modifier skeletal_bake adds
NODE_GROUP = "dg_skeletal"      # its node group

rigs = {}          # bind id -> SkeletalRig (rebuilt from the stored data after a reload)
rig_sources = {}   # bind id -> digest of the stored data text its rig was checked against


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


def has_binding(obj):
    """Whether ``obj`` is a mesh object with Skeletal Bind's custom property, valid or not."""
    return obj is not None and obj.type == 'MESH' and PROP in obj.keys()


def is_bound(obj):
    """Whether ``obj`` is a mesh object holding a binding: Skeletal Bind's custom property, a group
    of fields (``bind_problem`` checks them)."""
    return has_binding(obj) and hasattr(obj[PROP], "to_dict")


def bound_rig(obj, verify=False):
    """The SkeletalRig of a bound object, rebuilt from its stored data once per bind id (``rigs``).
    Raises BindDataError when the data cannot be read. ``verify``: also when the stored data is no
    longer the data the rig was rebuilt from (edited in the Custom Properties panel since)."""
    info = obj[PROP]
    bid = info["id"]
    rig = rigs.get(bid)
    digest = None
    if verify:
        digest = hashlib.blake2b(str(info["data"]).encode(), digest_size=16).digest()
        if rig_sources.get(bid) != digest:
            rig = None
    if rig is None:
        arrays = decode_arrays(info["data"])
        check_arrays(arrays, len(info["bones"]))
        try:
            rig = SkeletalRig.from_arrays(arrays)
        except (MeshError, ValueError, TypeError) as exc:
            raise BindDataError(f"its bind data is damaged ({exc})") from None
        rigs[bid] = rig
        if digest is not None:
            rig_sources[bid] = digest
    return rig


def bind_problem(obj):
    """Why the saved binding of ``obj`` (which has Skeletal Bind's property) cannot be used, as a
    sentence naming the object and the way out, or None when it is sound."""
    value = obj[PROP]
    try:
        check_info(value.to_dict() if hasattr(value, "to_dict") else value, [m.upper() for m in METHODS])
        bound_rig(obj, verify=True)
    except BindDataError as exc:
        return (f"The skeletal binding saved in {obj.name!r} (custom property {PROP!r}) is damaged: {exc}. "
                "Skeletal Unbind removes it; then bind again")
    return None


def fields_problem(obj):
    """Whether the saved binding's fields (not its bind data, whose check decodes it) break the
    schema: cheap enough for the sidebar panel, which then offers Skeletal Unbind."""
    value = obj[PROP]
    if not hasattr(value, "items"):
        return True
    def plain(v):
        return v.to_dict() if hasattr(v, "to_dict") else v.to_list() if hasattr(v, "to_list") else v

    fields = {k: plain(value[k]) for k in value.keys() if k != "data"}  # (reading the data copies it)
    if "data" in value:
        fields["data"] = ""
    try:
        check_info(fields, [m.upper() for m in METHODS])
    except BindDataError:
        return True
    return False


def salvaged(obj):
    """The fields of a binding as a dict for unbinding, each one the schema rejects (an edited or
    damaged property) replaced by an empty value: (fields, names of the fields replaced)."""
    value = obj[PROP]
    if not hasattr(value, "to_dict"):
        info, lost = {}, [f"the whole property ({type(value).__name__})"]
    else:
        info, lost = value.to_dict(), []
    for key, (check, _what, required) in INFO_FIELDS.items():
        if key in info and not check(info[key]):
            del info[key]
            lost.append(key)
        if key not in info and required:
            if hasattr(value, "to_dict"):
                lost.append(key)
            info[key] = [] if key in ("modifiers", "modifiers_viewport", "modifiers_render", "bones") else ""
    if "target" not in info and any(m.type == 'NODES' and m.node_group is not None
                                    and m.node_group.nodes.get(HELPER_NODE) is not None for m in obj.modifiers):
        info["target"] = "HELPER"  # (absent: a shape key, in bindings of the first versions)
    n = len(info["modifiers"])
    if any(len(info.get(k, [None] * n)) != n for k in ("modifiers_viewport", "modifiers_render", "modifiers_object")):
        lost.append("modifiers")
        for k in ("modifiers", "modifiers_viewport", "modifiers_render", "modifiers_object"):
            info[k] = []
    return info, lost


def state_key(obj, info):
    """Key of per-object live state: (bind id, object name); a duplicate shares the bind id."""
    return (info.get("id"), obj.name)


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


def purge_orphans(deleted_only=False):
    """The hidden helper and skeleton objects of a bound mesh that was deleted (hidden and
    unselectable, the user cannot find them to delete them); run at load, bind and unbind.
    ``deleted_only`` (the live handler, which may run in the middle of an operator binding a mesh):
    only those whose mesh is no longer in the file."""
    def gone(name):
        return not deleted_only or not isinstance(name, str) or name not in bpy.data.objects

    for h in [o for o in bpy.data.objects if OWNER in o.keys()]:
        if gone(h[OWNER]) and not helper_users(h):
            remove_object(h)
    for sk in [o for o in bpy.data.objects if SKELETON_OF in o.keys()]:
        if (sk.parent is None or not is_bound(sk.parent)) and (not deleted_only or sk.parent is None):
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
    sk = bpy.data.objects.get(str(obj[PROP].get("skeleton", "")))
    if sk is not None and sk.get(SKELETON_OF) is not None:
        return sk
    # Renamed: it is parented to its mesh.
    return next((c for c in obj.children if c.get(SKELETON_OF) is not None), None)
