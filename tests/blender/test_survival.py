"""Data the operator does not mean to change survives it."""

import bpy
import numpy as np

from helpers import DG_ATTRIBUTES, curvature_map, mesh_snapshot, open_fixture, select, without_dg

OBJECTS = ("DataRich", "ShapeKeyed")


def _object_state(obj):
    return {
        "vertex_groups": [(g.name, g.index) for g in obj.vertex_groups],
        "modifiers": [(m.name, m.type) for m in obj.modifiers],
        "active_shape_key_index": obj.active_shape_key_index,
        "matrix": tuple(map(tuple, obj.matrix_world)),
    }


def _check_fixture_has_everything():
    rich = bpy.data.objects["DataRich"]
    mesh = rich.data
    assert mesh.uv_layers and rich.vertex_groups and mesh.has_custom_normals
    assert {"my_float", "my_face_int", "my_corner_vec", "my_color"} <= set(mesh.attributes.keys())
    keyed = bpy.data.objects["ShapeKeyed"]
    assert keyed.data.shape_keys and keyed.modifiers


def _run_and_compare(edit_mode):
    open_fixture("data_survival")
    _check_fixture_has_everything()
    select(*OBJECTS, active="DataRich")
    if edit_mode:
        # The Edit-mode round trip itself is Blender's; compare against a
        # state that already went through it once.
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.object.mode_set(mode='OBJECT')
    before = {n: (mesh_snapshot(bpy.data.objects[n].data), _object_state(bpy.data.objects[n]))
              for n in OBJECTS}
    if edit_mode:
        bpy.ops.object.mode_set(mode='EDIT')
    assert curvature_map() == {'FINISHED'}
    if edit_mode:
        bpy.ops.object.mode_set(mode='OBJECT')

    for name in OBJECTS:
        obj = bpy.data.objects[name]
        snap_before, state_before = before[name]
        snap_after = mesh_snapshot(obj.data)
        assert set(DG_ATTRIBUTES) <= set(snap_after["attributes"])
        assert without_dg(snap_after) == without_dg(snap_before)
        assert _object_state(obj) == state_before
    mesh = bpy.data.objects["DataRich"].data
    assert mesh.color_attributes.active_color.name == "dg_curvature_color"
    # The user's colour attribute is still there, unchanged (checked above), just not active.
    assert "my_color" in mesh.color_attributes


def test_survives_object_mode():
    _run_and_compare(edit_mode=False)


def test_survives_edit_mode():
    _run_and_compare(edit_mode=True)


def test_shape_key_data_kept_and_basis_measured(dg):
    open_fixture("data_survival")
    obj = bpy.data.objects["ShapeKeyed"]
    basis = obj.data.shape_keys.key_blocks["Basis"]
    co = np.array([d.co[:] for d in basis.data])
    select("ShapeKeyed")
    assert curvature_map() == {'FINISHED'}
    # Measured on the mesh vertices = the basis shape (a unit sphere), not the squashed key.
    H = np.array([d.value for d in obj.data.attributes["dg_mean_curvature"].data])
    assert abs(np.median(H) - 1.0) < 0.1
    np.testing.assert_array_equal(np.array([d.co[:] for d in basis.data]), co)
