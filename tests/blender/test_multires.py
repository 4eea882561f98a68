"""dgmesh.multires_preview: control wireframe object, displacement colours, errors change nothing."""

import bpy
import numpy as np
import pytest

from helpers import attribute_array, independent_arrays, mesh_snapshot, open_fixture, select

OURS = ("dg_multires_displacement", "dg_multires_magnitude", "dg_multires_color")


def _run(**props):
    return bpy.ops.dgmesh.multires_preview('EXEC_DEFAULT', True, **props)


def _strip(snap):
    snap = dict(snap)
    snap["attributes"] = {k: v for k, v in snap["attributes"].items() if k not in OURS}
    snap.pop("active_color")
    snap.pop("render_color_index")
    return snap


def test_preview_adds_control_object_and_colours(dg, capsys):
    open_fixture("shapes")
    select("Torus")
    obj = bpy.data.objects["Torus"]
    before = mesh_snapshot(obj.data)
    assert _run(control_faces=200) == {'FINISHED'}
    assert "Multires preview of 'Torus'" in capsys.readouterr().out

    ctrl = bpy.data.objects["Torus_control"]
    assert ctrl.display_type == 'WIRE'
    assert ctrl.matrix_world == obj.matrix_world
    assert 150 <= len(ctrl.data.polygons) <= 240
    # The dense mesh keeps everything but gains the three attributes.
    assert _strip(mesh_snapshot(obj.data)) == _strip(before)
    V, F = independent_arrays(obj.data)
    mr = dg.Multires.build(V, F, control_faces=200)
    disp = attribute_array(obj.data.attributes["dg_multires_displacement"])[:, 0]
    np.testing.assert_allclose(disp, mr.normal_displacement.astype(np.float32), rtol=1e-4, atol=1e-6)
    assert obj.data.color_attributes.active_color.name == "dg_multires_color"
    assert len(attribute_array(obj.data.attributes["dg_multires_color"])) == len(obj.data.vertices)

    # A second run replaces the control object instead of adding another.
    assert _run(control_faces=100) == {'FINISHED'}
    controls = [o for o in bpy.data.objects if o.get("dgmesh_multires_control_of") == "Torus"]
    assert len(controls) == 1 and len(controls[0].data.polygons) <= 120


def test_bad_mesh_reports_error_and_changes_nothing():
    open_fixture("bad_meshes")
    select("Bad_NonManifoldEdge")
    obj = bpy.data.objects["Bad_NonManifoldEdge"]
    before = mesh_snapshot(obj.data)
    n_objects = len(bpy.data.objects)
    # An ERROR report surfaces as RuntimeError from bpy.ops in background mode.
    with pytest.raises(RuntimeError, match="Multires preview failed on 'Bad_NonManifoldEdge'.*non-manifold"):
        _run()
    assert mesh_snapshot(obj.data) == before
    assert len(bpy.data.objects) == n_objects


def test_undo_restores_the_mesh():
    open_fixture("shapes")
    select("QuadSphere")
    obj = bpy.data.objects["QuadSphere"]
    before = mesh_snapshot(obj.data)
    bpy.ops.ed.undo_push(message="before")
    assert _run(control_faces=100) == {'FINISHED'}
    assert bpy.ops.ed.undo() == {'FINISHED'}
    obj = bpy.data.objects["QuadSphere"]
    assert mesh_snapshot(obj.data) == before
    assert "QuadSphere_control" not in bpy.data.objects
