"""dgmesh.blender.bridge: bpy <-> numpy."""

import bpy
import numpy as np
import pytest

from helpers import attribute_array, independent_arrays, mesh_snapshot, open_fixture, select


@pytest.fixture
def bridge():
    from dgmesh.blender import bridge

    return bridge


def test_read_mesh_arrays(bridge):
    open_fixture("shapes")
    mesh = bpy.data.objects["NgonCylinder"].data
    before = mesh_snapshot(mesh)
    a = bridge.read_mesh(mesh, edges=True)
    assert mesh_snapshot(mesh) == before  # reading writes nothing

    V, F = independent_arrays(mesh)
    assert a.V.dtype == np.float64 and a.V.flags.c_contiguous and a.V.shape == (len(mesh.vertices), 3)
    assert a.F.dtype == np.int32 and a.F.flags.c_contiguous
    np.testing.assert_array_equal(a.V, V)
    np.testing.assert_array_equal(a.F, F)
    assert a.tri_loops.shape == a.F.shape and a.tri_poly.shape == (len(a.F),)

    loop_vertex = np.array([lp.vertex_index for lp in mesh.loops])
    np.testing.assert_array_equal(loop_vertex[a.tri_loops], a.F)
    # Each polygon with k corners gives k - 2 triangles.
    sizes = np.array([p.loop_total for p in mesh.polygons])
    np.testing.assert_array_equal(np.bincount(a.tri_poly, minlength=len(sizes)), sizes - 2)
    np.testing.assert_array_equal(a.edges, np.array([e.vertices[:] for e in mesh.edges], dtype=np.int32))
    assert bridge.read_mesh(mesh).edges is None


def test_read_evaluated_object(bridge):
    open_fixture("data_survival")
    obj = bpy.data.objects["ShapeKeyed"]  # subdivision modifier + shape key at 0.5
    orig = bridge.read_object(obj)
    ev = bridge.read_object(obj, evaluated=True)
    assert len(orig.V) == len(obj.data.vertices)
    assert len(ev.V) > len(orig.V) and len(ev.F) > len(orig.F)


def test_read_empty_mesh(bridge):
    open_fixture("bad_meshes")
    a = bridge.read_mesh(bpy.data.objects["Bad_Empty"].data, edges=True)
    assert a.V.shape == (0, 3) and a.F.shape == (0, 3) and a.edges.shape == (0, 2)


def test_write_positions(bridge):
    open_fixture("shapes")
    mesh = bpy.data.objects["QuadSphere"].data
    V = bridge.read_mesh(mesh).V * 2.0
    bridge.write_positions(mesh, V)
    np.testing.assert_allclose(bridge.read_mesh(mesh).V, V, rtol=1e-6)
    with pytest.raises(ValueError):
        bridge.write_positions(mesh, V[:-1])


def test_write_attributes(bridge):
    open_fixture("shapes")
    mesh = bpy.data.objects["QuadSphere"].data
    n = len(mesh.vertices)
    vals = np.linspace(-1, 1, n)
    bridge.write_point_float(mesh, "f", vals)
    np.testing.assert_allclose(attribute_array(mesh.attributes["f"])[:, 0], vals, rtol=1e-6)

    # Replacing an attribute of another domain/type under the same name.
    mesh.attributes.new("g", 'INT', 'FACE')
    bridge.write_point_float(mesh, "g", vals)
    assert (mesh.attributes["g"].domain, mesh.attributes["g"].data_type) == ('POINT', 'FLOAT')

    rgba = np.tile(np.array([[0.25, 0.5, 0.75, 1.0]], dtype=np.float32), (n, 1))
    for data_type in ('BYTE_COLOR', 'FLOAT_COLOR'):
        name = f"c_{data_type}"
        bridge.write_point_color(mesh, name, rgba, data_type)
        attr = mesh.attributes[name]
        assert (attr.domain, attr.data_type) == ('POINT', data_type)
        assert bridge.active_color_name(mesh) == name
        assert [a.name for a in mesh.color_attributes][mesh.color_attributes.render_color_index] == name
        np.testing.assert_allclose(attribute_array(attr), rgba, atol=0.01)  # bytes: 1/255 steps

    bridge.set_active_color(mesh, "c_BYTE_COLOR")
    assert bridge.active_color_name(mesh) == "c_BYTE_COLOR"
    with pytest.raises(KeyError):
        bridge.set_active_color(mesh, "f")  # not a colour attribute
    with pytest.raises(ValueError):
        bridge.write_point_float(mesh, "f", vals[:-1])
    with pytest.raises(ValueError):
        bridge.write_point_color(mesh, "c", rgba[:, :3])


def test_object_mode_context(bridge):
    open_fixture("shapes")
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    obj = bpy.data.objects["QuadSphere"]
    with bridge.object_mode(bpy.context):
        assert obj.mode == 'OBJECT'
        bridge.write_point_float(obj.data, "x", np.zeros(len(obj.data.vertices)))
    assert obj.mode == 'EDIT'
    bpy.ops.object.mode_set(mode='OBJECT')
    assert "x" in obj.data.attributes  # survived re-entering and leaving Edit mode
    with bridge.object_mode(bpy.context):  # no-op outside Edit mode
        assert obj.mode == 'OBJECT'
