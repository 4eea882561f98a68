"""dgmesh.curvature_map on valid meshes: values, colours, selections, Edit mode."""

import bmesh
import bpy
import numpy as np
import pytest

from helpers import attribute_array, curvature_map, independent_arrays, open_fixture, select

SHAPES = ("QuadSphere", "NgonCylinder", "SubdivCube", "Torus", "LooseVertex")


def _attr(mesh, name, domain='POINT', data_type='FLOAT'):
    attr = mesh.attributes.get(name)
    assert attr is not None, f"{mesh.name} has no attribute {name}"
    assert (attr.domain, attr.data_type) == (domain, data_type)
    return attribute_array(attr)


def _check_against_native(dg, mesh, kind='MEAN', percentile=95.0):
    from dgmesh import colors

    V, F = independent_arrays(mesh)
    ref = dg.curvature(V, F)
    H = _attr(mesh, "dg_mean_curvature")[:, 0]
    K = _attr(mesh, "dg_gaussian_curvature")[:, 0]
    np.testing.assert_allclose(H, ref.mean.astype(np.float32), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(K, ref.gaussian.astype(np.float32), rtol=1e-5, atol=1e-6)

    rgba = _attr(mesh, "dg_curvature_color", data_type='FLOAT_COLOR')
    field = ref.mean if kind == 'MEAN' else ref.gaussian
    np.testing.assert_allclose(rgba, colors.diverging(field, percentile=percentile), atol=1e-5)
    colors_group = mesh.color_attributes
    assert colors_group.active_color.name == "dg_curvature_color"
    names = [a.name for a in colors_group]
    assert colors_group.render_color_index == names.index("dg_curvature_color")
    return ref


def test_quads_and_ngons_several_objects(dg, capsys):
    open_fixture("shapes")
    select(*SHAPES)
    assert curvature_map() == {'FINISHED'}
    nverts = sum(len(bpy.data.objects[n].data.vertices) for n in SHAPES)
    assert f"Curvature map on 5 objects ({nverts} vertices): mean curvature range [" in capsys.readouterr().out
    refs = {name: _check_against_native(dg, bpy.data.objects[name].data) for name in SHAPES}

    # The n-gon caps and quads really were triangulated (16-gon -> 14 triangles).
    cyl = bpy.data.objects["NgonCylinder"].data
    assert max(p.loop_total for p in cyl.polygons) == 16
    assert len(independent_arrays(cyl)[1]) == sum(p.loop_total - 2 for p in cyl.polygons)

    # Sign conventions: unit sphere H ~ 1, K ~ 1; torus has K < 0 inside, > 0 outside.
    sphere = refs["QuadSphere"]
    assert abs(np.median(sphere.mean) - 1.0) < 0.05
    assert abs(np.median(sphere.gaussian) - 1.0) < 0.1
    torus = refs["Torus"].gaussian
    assert torus.min() < -0.5 and torus.max() > 0.5
    # Loose vertex (the last one) gets 0.
    loose = bpy.data.objects["LooseVertex"].data
    assert _attr(loose, "dg_mean_curvature")[-1, 0] == 0.0


def test_gaussian_kind_and_percentile(dg, capsys):
    open_fixture("shapes")
    select("Torus")
    assert curvature_map(kind='GAUSSIAN', percentile=80.0) == {'FINISHED'}
    assert "Gaussian curvature range" in capsys.readouterr().out
    _check_against_native(dg, bpy.data.objects["Torus"].data, kind='GAUSSIAN', percentile=80.0)
    # Running again replaces the attributes (no duplicates, e.g. ".001").
    assert curvature_map(kind='MEAN') == {'FINISHED'}
    mesh = bpy.data.objects["Torus"].data
    assert sorted(a.name for a in mesh.attributes if a.name.startswith("dg_")) == [
        "dg_curvature_color", "dg_gaussian_curvature", "dg_mean_curvature"]
    # Operator properties are remembered between calls (Blender's usual behaviour).
    _check_against_native(dg, mesh, kind='MEAN', percentile=80.0)


def test_replaces_attribute_of_other_type(dg):
    open_fixture("shapes")
    mesh = bpy.data.objects["QuadSphere"].data
    mesh.attributes.new("dg_mean_curvature", 'INT', 'FACE')
    mesh.color_attributes.new("dg_curvature_color", 'BYTE_COLOR', 'CORNER')
    select("QuadSphere")
    assert curvature_map() == {'FINISHED'}
    _check_against_native(dg, mesh)


def test_non_mesh_objects_and_linked_duplicates_are_skipped(capsys):
    open_fixture("shapes")
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    sphere = bpy.data.objects["QuadSphere"]
    twin = sphere.copy()  # shares the mesh datablock
    bpy.context.scene.collection.objects.link(twin)
    select("QuadSphere", twin.name, "Empty", active="Empty")
    assert curvature_map() == {'FINISHED'}
    out = capsys.readouterr().out
    assert f"Curvature map on 1 object ({len(sphere.data.vertices)} vertices)" in out
    assert "skipped 1 non-mesh object" in out
    assert "dg_mean_curvature" in sphere.data.attributes


def test_modifiers_use_original_mesh(dg, capsys):
    open_fixture("data_survival")
    obj = bpy.data.objects["ShapeKeyed"]
    assert obj.modifiers and obj.data.shape_keys
    select("ShapeKeyed")
    assert curvature_map() == {'FINISHED'}
    assert "1 object with modifiers: computed on the original mesh" in capsys.readouterr().out
    assert len(obj.data.attributes["dg_mean_curvature"].data) == len(obj.data.vertices)
    _check_against_native(dg, obj.data)


def test_edit_mode(dg):
    open_fixture("shapes")
    select("QuadSphere", "NgonCylinder", active="QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    # An edit made in Edit mode (not yet in the mesh datablock) must be seen and kept.
    sphere = bpy.data.objects["QuadSphere"]
    bm = bmesh.from_edit_mesh(sphere.data)
    bm.verts.ensure_lookup_table()
    bm.verts[100].co *= 1.3
    bmesh.update_edit_mesh(sphere.data)

    assert curvature_map() == {'FINISHED'}
    assert [bpy.data.objects[n].mode for n in ("QuadSphere", "NgonCylinder")] == ['EDIT', 'EDIT']
    bpy.ops.object.mode_set(mode='OBJECT')
    assert np.linalg.norm(sphere.data.vertices[100].co) == pytest.approx(1.3, rel=1e-5)
    ref = _check_against_native(dg, sphere.data)
    assert ref.mean[100] > 1.5  # the pulled-out vertex is a spike
    _check_against_native(dg, bpy.data.objects["NgonCylinder"].data)


def test_scanned_model(dg, capsys):
    """A real scan from Debian's CGAL data (unpacked into the cache on first use)."""
    from helpers import make_fixtures

    open_fixture("shapes")
    try:
        obj = make_fixtures.load_cgal_object("fandisk")
    except FileNotFoundError as exc:
        pytest.skip(str(exc))
    select(obj.name)
    assert curvature_map() == {'FINISHED'}
    assert f"({len(obj.data.vertices)} vertices)" in capsys.readouterr().out
    _check_against_native(dg, obj.data)
