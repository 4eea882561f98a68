"""Operators dgmesh.skeletal_bind / skeletal_rebind / skeletal_unbind / skeletal_bake (thesis chapter 6).

Bind (a mesh and an armature selected, the mesh active): the mesh is bound to the armature's
deform bones with the weights of its vertex groups named after them (distance-based Gaussian
weights when it has none). The bind data is stored in the .blend (a custom property of the mesh
object holding the compressed arrays), plus a hidden object ``<mesh>_skeleton`` showing the
skeletal mesh coloured by its medial-ball radius (thesis fig. 6.8), revealed by DG Mesh > Show
Skeleton. Both internal objects are disabled in viewports, not only hidden, so collection instances
of a bound character do not draw them.

Live update (skeletal_live.py): a hidden helper object holds each pose's offsets, which a
geometry-nodes modifier placed first in the stack adds to the positions.

Free-form skeleton editing (thesis 6.2): the skeleton object is a control object. Whatever Blender
does to it (its mesh edited or sculpted, shape keys, Lattice, Hook, Curve or Simple Deform
modifiers) reshapes the bound mesh around it with its thickness kept, live, alone or under the pose
(the edit first, then the bones). It acts hidden too: the live modifier's node group refers to it,
so every depsgraph evaluates it, renders and bakes included.

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

Renders deform with the binding's render settings (Untangle Creases Render), the viewport with its
own (Untangle Creases): the live update asks which depsgraph it serves.

Bake writes a frame range to a .pc2 point cache played by a Mesh Cache modifier, so renders and
exports need no add-on: each frame as the stack evaluates it up to the live deformation (shape keys
included; with the render settings unless Use Settings for is Viewport), the cache placed after
the live and Armature modifiers and before the others (a Subdivision Surface still applies).
Unbind removes everything bind added and leaves the mesh as it was. Removing the live modifier
unbinds as well; applying it does too, and keeps the pose it froze into the mesh (the Armature
modifiers come back disabled).
"""

import uuid
from typing import NamedTuple

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..core import MeshError
from ..skeletal import SkeletalDeformOptions, SkeletalMethod, SkeletalRig, SkeletalRigOptions
from ..skeletal_data import (SCHEMA_VERSION, contact_slide_ok, encode_arrays, joint_fillet_ok, render_untangle,
                             saved_options, write_pc2)
from . import bridge, compat
from .common import enum_id, enum_items, plural, poll_fail as _poll_fail, read_only_reason, set_handlers
from .skeletal_live import (HANDLERS, edited, helper_node_group, helper_object, link_skeleton, move_first,
                            render_settings, unbind, update_object)
from .skeletal_space import pose_matrices, rig_space, transformed
from .skeletal_store import (ARM_PTR, ARM_TAG, ATTR, CACHE, MOD, PROP, bind_problem, bound_armature, from_library,
                             has_binding, live_modifier, purge_orphans, rest_hash, rigs, skeleton_object, skeleton_of)

METHODS = enum_items(SkeletalMethod, {
    "variational": ("Variational", "Thesis 6.5: stitched per-triangle frames plus shape-preserving fairing"),
    "basic": ("Basic", "Thesis 6.3: homotopy reconstruction with fold and self-intersection fairing (comparison)"),
})
BIND_DEFAULTS = SkeletalRigOptions()  # property defaults: the library's own (dgmesh/skeletal.h)
DEFORM_DEFAULTS = SkeletalDeformOptions()
# Untangle Creases Render's default: off, as the viewport. On bench skeletal_joints' meshes and poses
# 3 to 20 iterations leave 0 crossing pairs on 14 of the 15 poses, but over an animation the
# untangled crease jumps between frames: a capsule's bend swept one degree per frame has 1651
# vertices move 5.3 edge lengths at once where the untangling starts, then tens by up to 4 edge
# lengths per degree (the fold guard alone: under 0.7; bench/tools/skeletal_s29/coherence.py). So it
# is for stills; 10 is the measured setting there.
RENDER_UNTANGLE = 0
SKELETON_BLENDS = (
    ('DUAL_QUATERNION', "Dual Quaternion", "Rigid per skeletal vertex, as Preserve Volume: a thick "
     "limb turned far about itself keeps its shape (the linear blend collapses its medial surface "
     "halfway through the joint and the mesh tears open there)"),
    ('LINEAR', "Linear", "Skeletal subspace deformation (eq. 6.2), as the thesis: about even in bends, "
     "tears thick limbs twisted far"),
)


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
    if not has_binding(context.active_object):
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


class DGMESH_OT_skeletal_show_skeleton(bpy.types.Operator):
    """Show or hide the skeletal mesh of the active bound object, coloured by medial-ball radius \
(thesis fig. 6.8); edit it (Edit or Sculpt mode, shape keys, Lattice or Hook modifiers) to reshape \
the mesh around it"""

    bl_idname = "dgmesh.skeletal_show_skeleton"
    bl_label = "Show Skeleton"
    bl_options = {'REGISTER', 'UNDO'}

    show: bpy.props.BoolProperty(name="Show", default=True)

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if not has_binding(obj) or (skeleton_of(obj) is None and bind_problem(obj) is None):
            return _poll_fail(cls, "The active object is not bound, or its skeleton was deleted")
        return True

    def execute(self, context):
        obj = context.active_object
        problem = bind_problem(obj) if has_binding(obj) else "The active object is not bound"
        if problem:
            self.report({'ERROR'}, problem)
            return {'CANCELLED'}
        sk = skeleton_of(obj)
        if sk is None:
            self.report({'ERROR'}, f"The skeleton object of {obj.name!r} was deleted (Skeletal Rebind makes it again)")
            return {'CANCELLED'}
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
    untangle: IntProperty(name="Untangle Creases", default=DEFORM_DEFAULTS.untangle_iterations, min=0, max=10,
                          description="Where a bent joint's skin crosses itself, smooth it out and push it back to "
                          "the bones' clearance, up to this many times per pose (thesis eq. 6.15's smoothing term; "
                          "0 = off), in the viewport. Fewer folds in the crease, several times slower per pose")
    untangle_render: IntProperty(name="Untangle Creases Render", default=RENDER_UNTANGLE, min=0, max=10,
                                 description="Untangle Creases in renders and in bakes for them (0 = off, the "
                                 "default; 10 for stills): the viewport stays as fast as without it. Not for "
                                 "animations: the untangled crease can jump from one frame to the next")
    fold_guard: IntProperty(name="Fold Guard", default=DEFORM_DEFAULTS.fold_guard, min=0, max=500,
                            description="Where the thickness steps turn faces over (the inner crease of a bent "
                            "joint), smooth their displacement with the neighbours' until none is turned, up to "
                            "this many times per pose (0 = off). Fewer folds in the crease at a small cost; no "
                            "search")
    contact: FloatProperty(name="Joint Contact", default=DEFORM_DEFAULTS.contact_slide, min=0.0, max=20.0,
                           description="At each bent joint the two limbs' flesh meets on the plane halfway between "
                           "the bones: crease vertices slide along their own bone, out of the other limb "
                           "(0 = off; 1 or more: how far along the bone the slide reaches, 3 measured best). "
                           "Fewer folds in tube-like limbs' creases; on thick, short limbs it can add some, "
                           "and in very tight bends of dense meshes it can thin the crease")
    follow_twist: BoolProperty(name="Follow Twist", default=DEFORM_DEFAULTS.follow_twist,
                               description="Keep the thickness in the untwisted pose, each vertex turned by its "
                               "own share of the bones' twist: a twisted flat or off-axis part (a waist, a wrist) "
                               "keeps its volume instead of swelling and crossing itself. Poses without twist are "
                               "unchanged")
    integrate_skeleton: BoolProperty(name="Integrate Skeleton", default=DEFORM_DEFAULTS.integrate_skeleton,
                                     description="Pose the skeletal mesh by rebuilding it from its rest edges "
                                     "turned by the blended bone rotations, held where one bone moves it alone: "
                                     "across a narrow blend the joint bends smoothly instead of swinging the flesh "
                                     "behind the joint backwards, and the crease folds less. The outer side of a "
                                     "tight bend is then pushed out by the bone clearance. Bindings made before "
                                     "this option keep it off")
    joint_fillet: FloatProperty(name="Joint Fillet", default=DEFORM_DEFAULTS.joint_fillet, min=0.0, max=10.0,
                                description="Bend each joint along an arc tangent to both bones, its radius "
                                "this many times the limb's radius where the weights allow (0: off): the flesh "
                                "of a bent elbow or knee turns as whole cross-sections instead of piling into "
                                "the crease. Bindings made before this option keep it off")
    ring_twist: BoolProperty(name="Twist by Rings", default=DEFORM_DEFAULTS.ring_twist,
                             description="Turn each cross-section of a limb as one under a twist: the twist is "
                             "blended with the weights evened out around the limb, so a knee or a forearm turned "
                             "far does not fold where its weights differ around it (front and back). Bends keep "
                             "the weights. Bindings made before this option keep it off")
    skeleton_blend: EnumProperty(
        name="Skeleton Blend", items=SKELETON_BLENDS,
        default='DUAL_QUATERNION' if DEFORM_DEFAULTS.dual_quaternion else 'LINEAR',
        description="How the bone motions are blended on the skeletal mesh where a vertex follows several bones")

    @classmethod
    def register(cls):
        set_handlers(HANDLERS)

    @classmethod
    def unregister(cls):
        set_handlers(HANDLERS, add=False)

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
        if has_binding(obj):
            problem = bind_problem(obj)
            self.report({'ERROR'}, problem or f"{obj.name!r} is already bound; unbind it first (DG Mesh > "
                        "Skeletal Unbind)")
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
        if ATTR in obj.data.attributes or MOD in obj.modifiers:
            self.report({'ERROR'}, f"{obj.name!r} already has an attribute {ATTR!r} or a modifier {MOD!r} "
                        "(left from an earlier binding?); remove them first")
            return {'CANCELLED'}
        if not joint_fillet_ok(self.joint_fillet):
            self.report({'ERROR'}, f"Joint Fillet is {self.joint_fillet:g}: set 0 (off) or a positive radius scale")
            return {'CANCELLED'}
        if not contact_slide_ok(self.contact):
            self.report({'ERROR'}, f"Joint Contact is {self.contact:g}: set 0 (off) or at least 1 (the slide "
                        "reaches that many times its crossing depth along the bone)")
            return {'CANCELLED'}
        settings = {k: getattr(self, k) for k in SETTINGS}
        try:
            binding = _compute_binding(context, obj, arm, settings)
            _attach(context, obj, arm, binding, settings)
        except _BindFailure as exc:
            self.report({'ERROR'}, f"Skeletal Bind failed on {obj.name!r}: {exc}")
            return {'CANCELLED'}
        rig = binding.rig
        others = [o.name for o in context.selected_objects if o.type == 'MESH' and o != obj]
        self.report({'INFO'}, f"Bound {obj.name!r} ({rig.n_vertices} vertices, control mesh {rig.n_control} vertices) "
                    f"to {len(binding.names)} deform bones of {arm.name!r}" + (
                        "" if binding.weighted else " with distance weights (no vertex groups)")
                    + (f"; only the active mesh is bound: bind {', '.join(map(repr, others[:3]))} one at a time"
                       if others else ""))
        _warn_control_crossings(self, obj, binding)
        return {'FINISHED'}


SETTINGS = ("control_faces", "fairing_steps", "method", "bone_clearance", "untangle", "untangle_render", "fold_guard",
            "contact", "follow_twist", "integrate_skeleton", "ring_twist", "joint_fillet", "skeleton_blend")


class _BindFailure(Exception):
    """Why a mesh cannot be bound (the operator's error report); nothing was changed."""


class _Binding(NamedTuple):
    rig: SkeletalRig
    names: list        # the deform bones, in the rig's order
    space: object      # rig_space (None: the mesh's object space)
    weighted: bool     # weights from vertex groups (else distance weights)
    crossings: tuple   # SkeletalRig.control_crossings: (control mesh, mesh) pairs at rest


def _warn_control_crossings(op, obj, binding):
    """A WARNING report when the binding's control mesh crosses itself at rest where the mesh does not
    (SkeletalRig.control_crossings): every pose folds the mesh there."""
    control, dense = binding.crossings
    if control > dense:
        op.report({'WARNING'}, f"The {len(binding.rig.control_faces)}-face control mesh of {obj.name!r} crosses "
                  f"itself at {control} triangle pairs at rest (the mesh at {dense}): poses will fold the mesh "
                  "there. Raise Control Faces and bind again")


def _compute_binding(context, obj, arm, settings):
    """The rig of ``obj`` bound to ``arm``'s deform bones, computed without changing anything;
    raises _BindFailure with the message to report."""
    names = [b.name for b in arm.data.bones if b.use_deform]
    if not names:
        raise _BindFailure(f"Armature {arm.name!r} has no deform bones")
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
            raise _BindFailure(f"{o.name!r} has zero scale (its transform cannot be inverted); give it a "
                               "non-zero scale first")
    space = rig_space(obj, arm)
    rest = pose_matrices(obj, arm, names, rest=True, space=space)
    to_mesh = obj.matrix_world.inverted() @ arm.matrix_world
    heads = np.array([tuple(to_mesh @ arm.data.bones[n].head_local) for n in names])
    tails = np.array([tuple(to_mesh @ arm.data.bones[n].tail_local) for n in names])
    if space is not None:
        V, heads, tails = (transformed(P, space) for P in (V, heads, tails))
        if np.linalg.det(space[:3, :3]) < 0:  # a mirror turns the surface inside out: re-orient
            F = F[:, ::-1].copy()
    wm = context.window_manager
    has_window = context.window is not None
    if has_window:
        wm.progress_begin(0, 100)
    try:
        rig = SkeletalRig.bind(V, F, rest, W, bone_heads=heads, bone_tails=tails,
                               control_faces=settings["control_faces"],
                               progress=(lambda f: wm.progress_update(int(100 * f)) or True) if has_window else None)
    except (MeshError, ValueError) as exc:
        msg = str(exc)
        if "no weight" in msg:
            msg += " (vertex groups must be named after deform bones: " + ", ".join(names[:8]) + ")"
        if "open" in msg or "boundary" in msg:
            if any(m.type == 'MIRROR' for m in obj.modifiers):
                msg += (" (the Mirror modifier closes it only in the evaluated mesh: apply the modifier "
                        "before binding)")
            else:
                msg += " (unmerged vertices along a seam? Mesh > Clean Up > Merge by Distance)"
        raise _BindFailure(msg) from None
    finally:
        if has_window:
            wm.progress_end()
    return _Binding(rig, names, space, W is not None, rig.control_crossings(F))


def _attach(context, obj, arm, binding, settings):
    """Stores a computed binding in ``obj`` (unbound): the live modifier, helper and skeleton objects,
    the custom property; the Armature modifiers are turned off. Raises _BindFailure having removed
    what it added."""
    rig, names, space = binding.rig, binding.names, binding.space
    bid = uuid.uuid4().hex
    # What the binding adds comes first and goes again if anything fails, before the user's
    # Armature modifiers are touched: a failure leaves the object as it was.
    helper = ng = mod = sk = None
    try:
        helper = helper_object(obj, rig.n_vertices)
        ng = helper_node_group(helper)
        mod = obj.modifiers.new(MOD, 'NODES')
        mod.node_group = ng
        move_first(obj, mod)
        sk = skeleton_object(context, obj, rig, space)
        link_skeleton(ng, sk)
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
        raise _BindFailure(f"{type(exc).__name__}: {exc}") from None
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
        "schema": SCHEMA_VERSION,
        "id": bid, "armature": arm.name, "armature_tag": tag, "armature_data": arm.data.name,
        "bind_to_mesh": [float(x) for x in np.array(obj.matrix_world.inverted() @ arm.matrix_world).ravel()],
        "bones": names, "data": encode_arrays(rig.to_arrays()),
        "bones_local": [float(x) for n in names for x in np.array(arm.data.bones[n].matrix_local).ravel()],
        "fairing_steps": settings["fairing_steps"], "method": settings["method"],
        "bone_clearance": settings["bone_clearance"], "skeleton_blend": settings["skeleton_blend"],
        "untangle_iterations": settings["untangle"], "untangle_render": settings["untangle_render"],
        "fold_guard": settings["fold_guard"],
        "contact_slide": settings["contact"], "follow_twist": int(settings["follow_twist"]),
        "integrate_skeleton": int(settings["integrate_skeleton"]), "ring_twist": int(settings["ring_twist"]),
        "joint_fillet": float(settings["joint_fillet"]),
        "control_faces": settings["control_faces"], "target": "HELPER",
        "modifier": mod.name, "node_group": ng.name, "helper": helper.name,
        "modifiers": [m[0] for m in disabled], "modifiers_viewport": [m[1] for m in disabled],
        "modifiers_render": [m[2] for m in disabled], "modifiers_object": [m[3] for m in disabled],
        "skeleton": sk.name, "rest_hash": rest_hash(obj.data),
    }
    if space is not None:
        obj[PROP]["space"] = [float(x) for x in space.ravel()]
    obj[ARM_PTR] = arm
    rigs[bid] = rig
    purge_orphans()
    update_object(obj, force=True)


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
        if not any(has_binding(o) for o in context.scene.objects):  # the sidebar names a bound object
            return _poll_fail(cls, "Nothing to rebind: the meshes in this scene are not bound "
                                   "(DG Mesh > Skeletal Bind)")
        return True

    def execute(self, context):
        obj = bpy.data.objects.get(self.object_name) if self.object_name else context.active_object
        if obj is None or not has_binding(obj):
            who = repr(self.object_name) if self.object_name else "The active object"
            self.report({'ERROR'}, f"{who} is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        reason = from_library(obj)
        if reason:
            self.report({'ERROR'}, reason)
            return {'CANCELLED'}
        problem = bind_problem(obj)
        if problem:
            self.report({'ERROR'}, problem)
            return {'CANCELLED'}
        info = obj[PROP]
        arm = bound_armature(obj, info)
        if arm is None:
            self.report({'ERROR'}, f"The armature {str(info['armature'])!r} of {obj.name!r} is gone: select an "
                        "armature and use Skeletal Unbind, then Skeletal Bind")
            return {'CANCELLED'}
        saved = saved_options(info)  # files bound before an option: the values they were bound with
        settings = dict(fairing_steps=int(info["fairing_steps"]), method=str(info["method"]),
                        bone_clearance=saved["bone_clearance"], untangle=saved["untangle_iterations"],
                        untangle_render=render_untangle(info), fold_guard=saved["fold_guard"],
                        contact=saved["contact_slide"],
                        follow_twist=saved["follow_twist"], integrate_skeleton=saved["integrate_skeleton"],
                        ring_twist=saved["ring_twist"], joint_fillet=saved["joint_fillet"],
                        skeleton_blend=saved["skeleton_blend"],
                        control_faces=saved["control_faces"])
        # The new binding is computed first: when the edited mesh no longer binds, the old binding stays.
        try:
            binding = _compute_binding(context, obj, arm, settings)
        except _BindFailure as exc:
            self.report({'ERROR'}, f"Cannot rebind {obj.name!r} (it keeps its binding): {exc}")
            return {'CANCELLED'}
        unbind(obj)
        try:
            _attach(context, obj, arm, binding, settings)
        except _BindFailure as exc:
            self.report({'ERROR'}, f"{obj.name!r} is unbound now; binding it again failed: {exc}")
            return {'CANCELLED'}
        self.report({'INFO'}, f"Rebound {obj.name!r} to {arm.name!r}")
        _warn_control_crossings(self, obj, binding)
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
        if not has_binding(obj):
            self.report({'ERROR'}, "The active object is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        reason = from_library(obj)
        if reason:
            self.report({'ERROR'}, reason)
            return {'CANCELLED'}
        lost = unbind(obj)
        purge_orphans()
        if lost:
            self.report({'WARNING'}, f"Unbound {obj.name!r}, whose saved binding was damaged (unreadable: "
                        f"{', '.join(lost)})" + (": check its Armature modifiers, which bind turned off"
                                                 if any(k.startswith(("modifiers", "the whole")) for k in lost) else ""))
        else:
            self.report({'INFO'}, f"Unbound {obj.name!r}")
        return {'FINISHED'}


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
    evaluation: EnumProperty(name="Use Settings for", default='RENDER',
                             items=(('RENDER', "Render", "The binding's render settings (Untangle Creases Render): "
                                     "the cache plays in renders and exports"),
                                    ('VIEWPORT', "Viewport", "The binding's viewport settings: the cache shows what "
                                     "the viewport shows")))

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
        if not has_binding(obj):
            self.report({'ERROR'}, "The active object is not bound (DG Mesh > Skeletal Bind)")
            return {'CANCELLED'}
        problem = bind_problem(obj)
        if problem:
            self.report({'ERROR'}, problem)
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
        if bound_armature(obj, info) is None:
            self.report({'ERROR'}, f"The armature {obj.name!r} was bound to ({info['armature']!r} at bind time) is "
                        "gone")
            return {'CANCELLED'}
        if edited(obj, info):
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
        live = live_modifier(obj, info)
        cut = _cache_index(obj, live)
        others = [m for m in obj.modifiers if m.name != CACHE]
        muted = [m for m in obj.modifiers if m.show_viewport and (m.name == CACHE or others.index(m) >= cut)]
        for m in muted:
            m.show_viewport = False
        if has_window:
            wm.progress_begin(self.frame_start, self.frame_end)
        try:
            with render_settings(self.evaluation == 'RENDER'):
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
