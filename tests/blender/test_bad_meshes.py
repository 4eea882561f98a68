"""Invalid meshes: an ERROR report naming the object, and the mesh untouched."""

import bpy
import pytest

from helpers import curvature_map, mesh_snapshot, open_fixture, select

BAD = ("Bad_NaN", "Bad_ZeroArea", "Bad_DuplicateFaces", "Bad_NonManifoldEdge",
       "Bad_NonManifoldVertex", "Bad_Empty", "Bad_FlippedFace")


def test_fixture_lists_every_bad_mesh():
    open_fixture("bad_meshes")
    assert sorted(o.name for o in bpy.data.objects) == sorted(BAD)


@pytest.mark.parametrize("name", BAD)
def test_bad_mesh_reports_error_and_is_untouched(name):
    open_fixture("bad_meshes")
    obj = bpy.data.objects[name]
    before = mesh_snapshot(obj.data)
    select(name)
    # bpy.ops turns an ERROR report into RuntimeError.
    with pytest.raises(RuntimeError) as info:
        curvature_map()
    message = str(info.value)
    assert f"Curvature map failed on '{name}'" in message
    assert obj["dg_expect_error"] in message.lower()
    assert mesh_snapshot(obj.data) == before


def test_mixed_selection_processes_valid_objects():
    open_fixture("bad_meshes")
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2)
    good = bpy.context.object
    snaps = {n: mesh_snapshot(bpy.data.objects[n].data) for n in ("Bad_NaN", "Bad_NonManifoldEdge")}
    select(good.name, "Bad_NaN", "Bad_NonManifoldEdge", active=good.name)
    with pytest.raises(RuntimeError) as info:
        curvature_map()
    message = str(info.value)
    assert "'Bad_NaN'" in message and "'Bad_NonManifoldEdge'" in message
    assert good.name not in message
    assert "dg_mean_curvature" in good.data.attributes
    for name, snap in snaps.items():
        assert mesh_snapshot(bpy.data.objects[name].data) == snap


def test_bad_mesh_in_edit_mode():
    open_fixture("bad_meshes")
    select("Bad_NonManifoldEdge")
    bpy.ops.object.mode_set(mode='EDIT')
    with pytest.raises(RuntimeError, match="non-manifold"):
        curvature_map()
    obj = bpy.data.objects["Bad_NonManifoldEdge"]
    assert obj.mode == 'EDIT'
    bpy.ops.object.mode_set(mode='OBJECT')
    assert not any(a.name.startswith("dg_") for a in obj.data.attributes)


@pytest.mark.parametrize("exc", [RuntimeError("boom"), MemoryError(), TypeError("bad argument")])
def test_other_native_errors_are_reported(dg, monkeypatch, exc):
    def failing(V, F):
        raise exc

    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    before = mesh_snapshot(obj.data)
    monkeypatch.setattr(dg, "curvature", failing)
    select("QuadSphere")
    with pytest.raises(RuntimeError, match=f"internal error: {type(exc).__name__}"):
        curvature_map()
    assert mesh_snapshot(obj.data) == before


@pytest.mark.parametrize("op", ["fair", "regularize", "remesh"])
def test_shape_keys_are_refused_by_position_changing_operators(op):
    """The shown shape is the active key's (the basis alone would change, and Edit mode brings the
    keys back; a new triangulation cannot carry them): a clear error, nothing changed."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=8, y_subdivisions=8) if op == "remesh" else \
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2)
    obj = bpy.context.object
    obj.shape_key_add(name="Basis")
    obj.shape_key_add(name="Key 1").value = 1.0
    before = mesh_snapshot(obj.data)
    select(obj.name)
    with pytest.raises(RuntimeError, match="shape keys"):
        getattr(bpy.ops.dgmesh, op)('EXEC_DEFAULT')
    assert mesh_snapshot(obj.data) == before


def test_fair_error_names_the_object_among_several():
    open_fixture("bad_meshes")
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2)
    good = bpy.context.object
    snap = mesh_snapshot(good.data)
    select(good.name, "Bad_NaN", active=good.name)
    with pytest.raises(RuntimeError, match="'Bad_NaN'"):
        bpy.ops.dgmesh.fair('EXEC_DEFAULT')
    assert mesh_snapshot(good.data) == snap  # all or nothing
