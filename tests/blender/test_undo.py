"""Undo of dgmesh.curvature_map, in Object and Edit mode.

Undo in ``blender --background`` (checked on 3.4) works without any window or
context override, with two catches:
* the first file loaded in a session leaves the undo stack without an initial
  step (the UI normally pushes one; later loads do get one), so undo would
  have nothing to go back to;
* an operator called from Python pushes no undo step unless the call passes
  undo=True: bpy.ops.x.y('EXEC_DEFAULT', True).
So each test pushes the "before" state itself with bpy.ops.ed.undo_push() and
runs the operator with undo=True (helpers.curvature_map); ed.undo() then steps
back to "before".
"""

import bpy

from helpers import DG_ATTRIBUTES, curvature_map, mesh_snapshot, open_fixture, select


def _dg_names(name):
    return sorted(a.name for a in bpy.data.objects[name].data.attributes if a.name in DG_ATTRIBUTES)


def test_undo_removes_attributes_object_mode():
    open_fixture("shapes")
    select("QuadSphere", "NgonCylinder")
    before = mesh_snapshot(bpy.data.objects["QuadSphere"].data)
    bpy.ops.ed.undo_push(message="before")
    assert curvature_map() == {'FINISHED'}
    assert _dg_names("QuadSphere") == sorted(DG_ATTRIBUTES)

    assert bpy.ops.ed.undo() == {'FINISHED'}
    # Memfile undo reloads the data: look objects up again.
    assert _dg_names("QuadSphere") == [] and _dg_names("NgonCylinder") == []
    assert mesh_snapshot(bpy.data.objects["QuadSphere"].data) == before

    assert bpy.ops.ed.redo() == {'FINISHED'}
    assert _dg_names("QuadSphere") == sorted(DG_ATTRIBUTES)
    assert _dg_names("NgonCylinder") == sorted(DG_ATTRIBUTES)


def test_undo_in_edit_mode():
    open_fixture("shapes")
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.ed.undo_push(message="before")
    assert curvature_map() == {'FINISHED'}
    assert bpy.context.object.mode == 'EDIT'
    assert bpy.ops.ed.undo() == {'FINISHED'}
    assert bpy.context.object.mode == 'EDIT'
    bpy.ops.object.mode_set(mode='OBJECT')
    assert _dg_names("QuadSphere") == []


def test_failed_run_pushes_no_undo_step():
    open_fixture("bad_meshes")
    select("Bad_NaN")
    # Mark two undo steps so we can tell which one undo returns to.
    bpy.context.scene["dg_step"] = 1
    bpy.ops.ed.undo_push(message="first")
    bpy.context.scene["dg_step"] = 2
    bpy.ops.ed.undo_push(message="second")
    try:
        curvature_map()
    except RuntimeError:
        pass
    # A cancelled operator adds no step, so one undo goes back to "first".
    assert bpy.ops.ed.undo() == {'FINISHED'}
    assert bpy.context.scene["dg_step"] == 1
