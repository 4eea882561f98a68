"""Saved skeletal state that no longer holds (issue #34): a failed rebind keeps the binding, a
damaged or hand-edited ``dg_skeletal`` custom property gets a clear report and Skeletal Unbind
always removes it, and a deleted bound mesh takes its hidden objects with it."""

import bmesh
import bpy
import numpy as np
import pytest

from dgmesh.skeletal import capsule
from helpers import add_armature, add_mesh_object
from dgmesh.skeletal_data import SCHEMA_VERSION, BindDataError, check_info, decode_arrays, encode_arrays


def _scene():
    """A capsule with two vertex groups and an Armature modifier, and its two-bone rig, both
    selected, the capsule active."""
    bpy.ops.wm.read_homefile(use_empty=True)
    V, F = capsule(0.5, 6.0, 16, 4, 16)
    obj = add_mesh_object("Capsule", V, F)
    arm = add_armature([("Upper", (-3.5, 0, 0), (0, 0, 0), None, False),
                        ("Lower", (0, 0, 0), (3.5, 0, 0), "Upper", False)])
    g1, g2 = obj.vertex_groups.new(name="Upper"), obj.vertex_groups.new(name="Lower")
    for i, x in enumerate(V[:, 0]):
        t = float(np.clip(x + 0.5, 0, 1))
        g1.add([i], 1 - t, 'REPLACE')
        g2.add([i], t, 'REPLACE')
    obj.modifiers.new("Armature", 'ARMATURE').object = arm
    for o in bpy.context.view_layer.objects:
        o.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj, arm


def _bound():
    obj, arm = _scene()
    assert bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT') == {'FINISHED'}
    return obj, arm


def _state(obj):
    """What the binding consists of on the object: its property, modifiers and internal objects."""
    return {"prop": obj["dg_skeletal"].to_dict() if hasattr(obj.get("dg_skeletal"), "to_dict")
            else obj.get("dg_skeletal"),
            "modifiers": [(m.name, m.type, m.show_viewport, m.show_render, getattr(m, "object", None))
                          for m in obj.modifiers],
            "objects": sorted(o.name for o in bpy.data.objects)}


def _open_a_hole(obj):
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.delete(bm, geom=[next(iter(bm.faces))], context='FACES_ONLY')
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def test_failed_rebind_keeps_the_binding():
    """The mesh edited so that it no longer binds (opened): Rebind reports why and changes nothing
    (it used to leave the object unbound with its Armature modifier back on)."""
    obj, arm = _bound()
    _open_a_hole(obj)
    before = _state(obj)
    with pytest.raises(RuntimeError, match="keeps its binding"):
        bpy.ops.dgmesh.skeletal_rebind('EXEC_DEFAULT', object_name=obj.name)
    assert _state(obj) == before
    assert before["modifiers"][1][2:] == (False, False, None)  # the Armature modifier stays off


def test_bind_stores_the_schema_version():
    obj, arm = _bound()
    assert obj["dg_skeletal"]["schema"] == SCHEMA_VERSION
    check_info(obj["dg_skeletal"].to_dict())


# Ways the custom property gets damaged: (name, how), each applied to a bound object.
def _set(key, value):
    def damage(obj):
        obj["dg_skeletal"][key] = value
    return damage


def _delete(key):
    def damage(obj):
        del obj["dg_skeletal"][key]
    return damage


def _replace(value):
    def damage(obj):
        obj["dg_skeletal"] = value
    return damage


def _wrong_arrays(obj):
    arrays = decode_arrays(obj["dg_skeletal"]["data"])
    arrays["weights"] = arrays["weights"][:, :1]  # one bone's weights for two bones
    obj["dg_skeletal"]["data"] = encode_arrays(arrays)


DAMAGE = {
    "property_is_an_int": _replace(5),
    "property_is_a_text": _replace("bound"),
    "data_is_not_base64": _set("data", "not the bind data"),
    "data_is_a_pickle_header": _set("data", "gASVAAAAAAAAAAA="),
    "data_cut_short": lambda obj: _set("data", obj["dg_skeletal"]["data"][:4000])(obj),
    "data_arrays_disagree": _wrong_arrays,
    "id_missing": _delete("id"),
    "bones_is_an_int": _set("bones", 3),
    "fairing_steps_is_a_text": _set("fairing_steps", "many"),
    "untangle_is_negative": _set("untangle_iterations", -2),
    "untangle_is_a_text": _set("untangle_iterations", "3"),
    "fold_guard_is_negative": _set("fold_guard", -1),
    "untangle_render_is_negative": _set("untangle_render", -1),
    "untangle_render_is_a_text": _set("untangle_render", "10"),
    "contact_slide_below_one": _set("contact_slide", 0.5),
    "contact_slide_is_a_text": _set("contact_slide", "3"),
    "follow_twist_is_a_text": _set("follow_twist", "yes"),
    "integrate_skeleton_is_a_text": _set("integrate_skeleton", "on"),
    "ring_twist_is_a_text": _set("ring_twist", "on"),
    "joint_fillet_is_negative": _set("joint_fillet", -1.0),
    "joint_fillet_is_a_text": _set("joint_fillet", "2"),
    "method_unknown": _set("method", "MAGIC"),
    "modifiers_lengths_differ": _set("modifiers_viewport", [1, 1, 1]),
    "space_wrong_size": _set("space", [1.0, 2.0]),
    "newer_schema": _set("schema", SCHEMA_VERSION + 1),
}


@pytest.mark.parametrize("damage", DAMAGE, ids=list(DAMAGE))
def test_damaged_property_is_reported_and_unbind_removes_it(damage):
    """Bake, Show Skeleton, Rebind and Bind report the damage and how out (they raised tracebacks,
    or said "already bound"); the live update does not raise; Unbind removes the binding whole."""
    obj, arm = _bound()
    DAMAGE[damage](obj)
    bpy.context.scene.frame_set(2)  # the live handler meets the damaged property: no exception
    for op, kw in ((bpy.ops.dgmesh.skeletal_bake, {"filepath": "/tmp/never_written.pc2"}),
                   (bpy.ops.dgmesh.skeletal_show_skeleton, {}),
                   (bpy.ops.dgmesh.skeletal_rebind, {}),
                   (bpy.ops.dgmesh.skeletal_bind, {})):
        before = _state(obj)
        with pytest.raises(RuntimeError, match="is damaged.*Skeletal Unbind removes it"):
            op('EXEC_DEFAULT', **kw)
        assert _state(obj) == before, op
    assert bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT') == {'FINISHED'}
    assert "dg_skeletal" not in obj.keys() and "dg_skeletal" not in obj.modifiers
    assert sorted(o.name for o in bpy.data.objects) == ["Capsule", "Rig"]  # helper and skeleton gone
    assert "dg_skeletal" not in bpy.data.node_groups
    assert bpy.ops.dgmesh.skeletal_bind('EXEC_DEFAULT') == {'FINISHED'}  # and it binds again


def test_unbind_of_a_damaged_property_restores_what_it_still_says():
    """A damaged field does not stop Unbind restoring the Armature modifier the rest describes."""
    obj, arm = _bound()
    obj["dg_skeletal"]["data"] = "damaged"
    bpy.ops.dgmesh.skeletal_unbind('EXEC_DEFAULT')
    m = obj.modifiers["Armature"]
    assert (m.show_viewport, m.show_render, m.object) == (True, True, arm)


def test_check_info_names_the_field():
    with pytest.raises(BindDataError, match="'fairing_steps' must be an integer"):
        check_info({"id": "x", "armature": "Rig", "bones": ["A"], "data": "", "fairing_steps": "3",
                    "method": "BASIC", "modifiers": [], "modifiers_viewport": [], "modifiers_render": [],
                    "skeleton": "s"})


def test_deleting_a_bound_mesh_removes_its_hidden_objects_at_once():
    """The hidden helper and skeleton objects go at the next update after the bound mesh is
    deleted, not only at the next load or bind."""
    obj, arm = _bound()
    assert "Capsule_dg_offsets" in bpy.data.objects and "Capsule_skeleton" in bpy.data.objects
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    assert bpy.ops.object.delete() == {'FINISHED'}
    bpy.context.view_layer.update()
    assert sorted(o.name for o in bpy.data.objects) == ["Rig"]


@pytest.mark.parametrize("damage", DAMAGE, ids=list(DAMAGE))
def test_sidebar_check_flags_damaged_fields(damage):
    """The sidebar panel's cheap check (the fields, not the bind data) flags what it can see."""
    from dgmesh.blender.skeletal_store import fields_problem

    obj, arm = _bound()
    assert not fields_problem(obj)
    DAMAGE[damage](obj)
    assert fields_problem(obj) == (not damage.startswith("data_"))
