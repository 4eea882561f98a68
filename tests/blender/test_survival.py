"""Data the operator does not mean to change survives it."""

import bpy
import numpy as np
import pytest

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


@pytest.mark.parametrize("op, props", [("fair", dict(subdivisions=1)), ("remesh", dict(target_vertices=150))])
def test_new_faces_carry_generic_corner_attributes(op, props):
    """Faces an operator makes (Fair's subdivision, Remesh's triangulation) get the generic corner
    attributes of the faces they replace, like UVs and colours (they were zero)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add()
    mesh = bpy.context.object.data
    lv = np.array([l.vertex_index for l in mesh.loops])
    z = np.array([v.co.z for v in mesh.vertices])[lv]
    mesh.attributes.new("c_float", 'FLOAT', 'CORNER').data.foreach_set("value", 2.0 + z)
    mesh.attributes.new("c_int", 'INT', 'CORNER').data.foreach_set("value", np.full(len(lv), 7))
    vec = np.stack([z, np.ones_like(z), -z], 1)
    mesh.attributes.new("c_vec", 'FLOAT_VECTOR', 'CORNER').data.foreach_set("vector", vec.ravel())
    sel = np.array([p.center.z > 0.6 for p in mesh.polygons])
    mesh.vertices.foreach_set("select", np.zeros(len(mesh.vertices), bool))
    mesh.edges.foreach_set("select", np.zeros(len(mesh.edges), bool))
    mesh.polygons.foreach_set("select", sel)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_mode(type='FACE')
    assert getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT', **props) == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    new = np.array([l for p in mesh.polygons if p.select for l in p.loop_indices])
    assert len(new) > 3 * sel.sum()  # the region was rebuilt with more faces
    lv = np.array([l.vertex_index for l in mesh.loops])
    z = np.array([v.co.z for v in mesh.vertices])[lv]
    f = np.array([d.value for d in mesh.attributes["c_float"].data])
    i = np.array([d.value for d in mesh.attributes["c_int"].data])
    v = np.array([d.vector[:] for d in mesh.attributes["c_vec"].data])
    # Interpolated from the polygons the corners lie on: close to 2 + z (the sphere's cap).
    assert np.abs(f[new] - (2.0 + z[new])).max() < 0.1
    assert np.all(i[new] == 7)
    assert np.abs(v[new][:, 1] - 1).max() < 1e-5 and np.abs(v[new][:, 0] - z[new]).max() < 0.1
