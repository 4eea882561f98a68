"""dgmesh.denoise and dgmesh.similarity_map inside Blender."""

import re

import bpy
import numpy as np
import pytest

from helpers import (attribute_array, independent_arrays, keep_mirror_half, mesh_snapshot, open_fixture, run_windowed,
                     select)
from make_fixtures import add_mesh_object

from dgmesh.blender import ops_denoise as ADDON  # noqa: E402


def denoise(**props):
    """Run the operator the way the UI does: with an undo push."""
    return bpy.ops.dgmesh.denoise('EXEC_DEFAULT', True, **props)


def similarity_map(**props):
    return bpy.ops.dgmesh.similarity_map('EXEC_DEFAULT', True, **props)


def coords(mesh):
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def set_coords(mesh, V):
    mesh.vertices.foreach_set("co", np.asarray(V, dtype=np.float32).ravel())
    mesh.update()


def add_noise(obj, level=0.15, seed=0):
    """Noise along the vertex normals, level times the mean edge length (float32 as Blender stores)."""
    mesh = obj.data
    V = coords(mesh).astype(np.float64)
    E = np.empty(len(mesh.edges) * 2, dtype=np.int32)
    mesh.edges.foreach_get("vertices", E)
    E = E.reshape(-1, 2)
    e = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1).mean()
    N = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("normal", N)
    rng = np.random.default_rng(seed)
    set_coords(mesh, V + N.reshape(-1, 3) * rng.normal(0, level * e, (len(V), 1)))
    return coords(mesh)


def noisy_icosphere(name, dg, level=3, noise=0.2, seed=1):
    V, F = dg.shapes.icosphere(level, 1.0)
    e = np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2).mean()
    rng = np.random.default_rng(seed)
    Vn = V + V * rng.normal(0, noise * e, (len(V), 1))
    return V, F, Vn


def test_object_mode_several_objects_quads_and_ngons(dg, capsys):
    open_fixture("shapes")
    names = ("QuadSphere", "NgonCylinder")
    before = {n: add_noise(bpy.data.objects[n], seed=i) for i, n in enumerate(names)}
    # Blender's triangulation of the noisy mesh, the one the operator reads (5.x splits quads and
    # n-gons by vertex positions: the denoised mesh may triangulate differently).
    tris = {n: independent_arrays(bpy.data.objects[n].data)[1] for n in names}
    select(*names)
    assert denoise() == {'FINISHED'}
    out = capsys.readouterr().out
    assert "Denoised 2 objects" in out
    # The report names what ran: the filter, or the automatic choice's smoothing (per object).
    ran = r"(similarity, 3 iterations|Taubin smoothing, \d+ steps?)"
    assert re.search(rf"with {ran}( / {ran})*( \(per object\))?, in ", out), out
    assert "residual entropy" in out and " s;" in out
    for n in names:
        mesh = bpy.data.objects[n].data
        assert max(p.loop_total for p in mesh.polygons) >= 4  # still quads / n-gons
        after = coords(mesh)
        # Same answer as the numpy API on Blender's own triangulation of the noisy mesh.
        mesh_before = before[n].astype(np.float64)
        ref = dg.denoise(mesh_before, tris[n]).vertices
        np.testing.assert_allclose(after, ref.astype(np.float32), atol=1e-5)
        assert np.abs(after - before[n]).max() > 1e-4


def test_operator_reports_the_estimated_noise(dg, capsys):
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    noisy = add_noise(obj, level=0.2).astype(np.float64)
    _, F = independent_arrays(obj.data)
    select("QuadSphere")
    assert denoise() == {'FINISHED'}
    out = capsys.readouterr().out
    est = dg.estimate_noise(noisy, F)
    auto = dg.denoise(noisy, F).options
    assert f"estimated noise {est.sigma:.3f} edge lengths" in out
    assert f"\u03b71 {auto.eta1:.3f}" in out
    # Manual etas: no estimate to report.
    assert denoise(automatic=False) == {'FINISHED'}
    assert "estimated noise" not in capsys.readouterr().out


def test_edit_mode_moves_selected_vertices_only(dg):
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    noisy = add_noise(obj)
    sel = noisy[:, 2] > 0
    obj.data.vertices.foreach_set("select", sel)
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    assert denoise() == {'FINISHED'}
    assert obj.mode == 'EDIT'
    bpy.ops.object.mode_set(mode='OBJECT')
    after = coords(obj.data)
    assert np.array_equal(after[~sel], noisy[~sel])
    assert (np.linalg.norm(after[sel] - noisy[sel], axis=1) > 0).mean() > 0.9
    # The fixed vertices still informed the filter: same as the API with the mask.
    _, F = independent_arrays(obj.data)
    ref = dg.denoise(noisy.astype(np.float64), F, mask=sel).vertices
    np.testing.assert_allclose(after, ref.astype(np.float32), atol=1e-5)


def test_edit_mode_without_selection_is_an_error():
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='DESELECT')
    before = coords(obj.data).copy()
    with pytest.raises(RuntimeError, match="no vertices selected"):
        denoise()
    bpy.ops.object.mode_set(mode='OBJECT')
    assert np.array_equal(coords(obj.data), before)


def test_undo_restores_the_mesh():
    open_fixture("shapes")
    obj = bpy.data.objects["NgonCylinder"]
    add_noise(obj)
    select("NgonCylinder")
    bpy.ops.ed.undo_push(message="before")
    before = mesh_snapshot(obj.data)
    assert denoise(show_residual=True) == {'FINISHED'}
    assert mesh_snapshot(bpy.data.objects["NgonCylinder"].data) != before
    assert bpy.ops.ed.undo() == {'FINISHED'}
    assert mesh_snapshot(bpy.data.objects["NgonCylinder"].data) == before


def test_undo_in_edit_mode():
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    noisy = add_noise(obj)
    select("QuadSphere")
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.ed.undo_push(message="before")
    assert denoise() == {'FINISHED'}
    assert bpy.ops.ed.undo() == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    assert np.array_equal(coords(bpy.data.objects["QuadSphere"].data), noisy)


def test_show_residual_writes_attributes(dg):
    open_fixture("shapes")
    obj = bpy.data.objects["Torus"]
    noisy = add_noise(obj)
    select("Torus")
    assert denoise(show_residual=True) == {'FINISHED'}
    mesh = obj.data
    res = attribute_array(mesh.attributes["dg_denoise_residual"])[:, 0]
    np.testing.assert_allclose(res, np.linalg.norm(coords(mesh) - noisy, axis=1), atol=1e-6)
    col = mesh.attributes["dg_denoise_residual_color"]
    assert (col.domain, col.data_type) == ('POINT', 'FLOAT_COLOR')
    assert mesh.color_attributes.active_color.name == "dg_denoise_residual_color"


def test_method_and_etas_reach_the_filter(dg):
    open_fixture("shapes")
    obj = bpy.data.objects["QuadSphere"]
    noisy = add_noise(obj).astype(np.float64)
    _, F = independent_arrays(obj.data)  # the triangles the operator reads
    select("QuadSphere")
    assert denoise(method='BILATERAL', automatic=False, eta1=0.3, eta2=1.5, eta3=0.8, iterations=2) == {'FINISHED'}
    ref = dg.denoise(noisy, F, method="bilateral", eta1=0.3, eta2=1.5, eta3=0.8, iterations=2).vertices
    np.testing.assert_allclose(coords(obj.data), ref.astype(np.float32), atol=1e-5)


def test_triangle_soup_stays_crack_free(dg):
    open_fixture("shapes")
    _, F, Vn = noisy_icosphere("Soup", dg)
    soup = add_mesh_object("Soup", Vn[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3))
    select("Soup")
    assert denoise() == {'FINISHED'}
    out = coords(soup.data).reshape(-1, 3, 3)
    # Copies of one original vertex end up on one point.
    flat = out.reshape(-1, 3)
    ids = F.ravel()
    for v in range(0, Vn.shape[0], 7):
        pts = flat[ids == v]
        assert np.ptp(pts, axis=0).max() == 0.0
    ref = dg.denoise(Vn.astype(np.float32).astype(np.float64), F).vertices
    np.testing.assert_allclose(out, ref[F].astype(np.float32), atol=1e-5)


def test_point_cloud_with_normal_attribute(dg, capsys):
    open_fixture("shapes")
    V, F, Vn = noisy_icosphere("Cloud", dg, level=3)
    cloud = add_mesh_object("Cloud", Vn, [])
    select("Cloud")
    before = mesh_snapshot(cloud.data)
    with pytest.raises(RuntimeError, match="attribute 'Normal'"):  # a name Blender 3.4 lets one create
        denoise()
    assert mesh_snapshot(cloud.data) == before
    # Blender 3.4 reserves "normal" (new() returns None); "Normal" is accepted as well.
    attr = (cloud.data.attributes.new("normal", 'FLOAT_VECTOR', 'POINT')
            or cloud.data.attributes.new("Normal", 'FLOAT_VECTOR', 'POINT'))
    attr.data.foreach_set("vector", V.astype(np.float32).ravel())
    assert denoise() == {'FINISHED'}
    assert "1 point cloud" in capsys.readouterr().out
    rad0 = np.linalg.norm(Vn, axis=1)
    rad = np.linalg.norm(coords(cloud.data), axis=1)
    assert rad.std() < rad0.std() / 2


def test_bad_mesh_reports_error_and_changes_nothing():
    open_fixture("bad_meshes")
    obj = bpy.data.objects["Bad_NaN"]
    select("Bad_NaN")
    before = mesh_snapshot(obj.data)
    with pytest.raises(RuntimeError, match="non-finite"):
        denoise(show_residual=True)
    assert mesh_snapshot(obj.data) == before


def test_shape_keys_are_refused():
    open_fixture("data_survival")
    obj = bpy.data.objects["ShapeKeyed"]
    select("ShapeKeyed")
    before = mesh_snapshot(obj.data)
    with pytest.raises(RuntimeError, match="shape keys"):
        denoise()
    assert mesh_snapshot(obj.data) == before


def test_cancel_leaves_meshes_unchanged(capsys):
    open_fixture("shapes")
    select("QuadSphere", "Torus")
    snaps = {n: mesh_snapshot(bpy.data.objects[n].data) for n in ("QuadSphere", "Torus")}
    ADDON.cancel_event.set()  # what Esc does in the modal run
    assert denoise(show_residual=True) == {'CANCELLED'}
    assert "Denoise: cancelled, nothing was changed" in capsys.readouterr().out
    assert not ADDON.cancel_event.is_set()
    for n, snap in snaps.items():
        assert mesh_snapshot(bpy.data.objects[n].data) == snap
    assert denoise() == {'FINISHED'}


def test_similarity_map_object_and_edit_mode(dg):
    open_fixture("shapes")
    obj = bpy.data.objects["SubdivCube"]
    select("SubdivCube")
    assert similarity_map(vertex=5) == {'FINISHED'}
    mesh = obj.data
    w = attribute_array(mesh.attributes["dg_similarity"])[:, 0]
    V, F = independent_arrays(mesh)
    np.testing.assert_allclose(w, dg.similarity(V, F, 5).astype(np.float32), atol=1e-6)
    assert w[5] == pytest.approx(1.0)
    assert mesh.color_attributes.active_color.name == "dg_similarity_color"
    # Edit mode: the active vertex.
    bpy.ops.object.mode_set(mode='EDIT')
    import bmesh

    bm = bmesh.from_edit_mesh(mesh)
    bm.verts.ensure_lookup_table()
    for v in bm.verts:
        v.select = False
    bm.verts[9].select = True
    bm.select_history.clear()
    bm.select_history.add(bm.verts[9])
    bmesh.update_edit_mesh(mesh)
    assert similarity_map(mode='FILTER') == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    w = attribute_array(mesh.attributes["dg_similarity"])[:, 0]
    assert w[9] == pytest.approx(1.0)
    np.testing.assert_allclose(w, dg.similarity(V, F, 9, mode="filter").astype(np.float32), atol=1e-6)


MODAL_SCRIPT = r'''
import numpy as np

def coords(mesh):
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    return co

def setup():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=7)  # 40962 vertices: a run of about a second
    obj = bpy.context.active_object
    V = coords(obj.data).reshape(-1, 3)
    rng = np.random.default_rng(0)
    obj.data.vertices.foreach_set("co", (V * (1 + rng.normal(0, 0.005, (len(V), 1)))).astype(np.float32).ravel())
    obj.data.update()
    state["before"] = coords(obj.data).copy()

def step():
    ph = state["phase"]
    mesh = bpy.context.active_object.data if bpy.context.active_object else None
    if ph == 0:
        setup()
        out["first"] = sorted(invoke('denoise', ))
        state["t0"], state["phase"] = time.time(), 1
    elif ph == 1:
        if not np.array_equal(coords(mesh), state["before"]):
            out["moved"] = True
            ops = bpy.context.window_manager.operators
            out["last_operator"] = ops[-1].bl_idname if len(ops) else None
            state["phase"] = 2
        elif time.time() - state["t0"] > 60:
            out["moved"] = False
            state["phase"] = 2
    elif ph == 2:
        setup()
        out["second"] = invoke_to_cancel('denoise', automatic=False, iterations=10)  # long enough to be cancelled midway
        state["phase"] = 3
        return 0.0
    elif ph == 3:
        if esc_until_worker_ends():
            state["phase"] = 4
        return 0.3
    else:
        out["unchanged_after_esc"] = bool(np.array_equal(coords(mesh), state["before"]))
        report_and_quit()
        return None
    return 0.2
'''


@pytest.mark.skipif(not __import__("shutil").which("xvfb-run"), reason="needs xvfb-run for a windowed Blender")
def test_interactive_run_is_modal_and_esc_cancels(tmp_path):
    """With a window (Xvfb), invoke runs the work in a thread; a simulated Esc cancels a run and
    leaves the mesh unchanged. (The background test session has no event loop for this.)"""
    out = run_windowed(tmp_path, MODAL_SCRIPT)
    assert out["first"] == ['RUNNING_MODAL'] and out["moved"]
    assert out["last_operator"] == "DGMESH_OT_denoise"
    assert out["second"] == ['RUNNING_MODAL'] and out["unchanged_after_esc"]


SIMILARITY_MODAL_SCRIPT = r"""

def setup():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=7)  # 40962 vertices

def has_map():
    return "dg_similarity" in bpy.context.active_object.data.attributes

def step():
    ph = state["phase"]
    if ph == 0:
        setup()
        out["first"] = sorted(invoke('similarity_map', vertex=3))
        state["t0"], state["phase"] = time.time(), 1
    elif ph == 1:
        if has_map():
            ops = bpy.context.window_manager.operators
            out["mapped"], out["last_operator"] = True, ops[-1].bl_idname if len(ops) else None
            state["phase"] = 2
        elif time.time() - state["t0"] > 60:
            out["mapped"], state["phase"] = False, 2
    elif ph == 2:
        setup()
        out["second"] = invoke_to_cancel('similarity_map', vertex=3, eta3=20.0)  # seconds of work: cancelled midway
        state["phase"] = 3
        return 0.0
    elif ph == 3:
        if esc_until_worker_ends():
            state["phase"] = 4
        return 0.3
    else:
        out["no_map_after_esc"] = not has_map()
        report_and_quit()
        return None
    return 0.2
"""


@pytest.mark.skipif(not __import__("shutil").which("xvfb-run"), reason="needs xvfb-run for a windowed Blender")
def test_similarity_map_runs_modal_and_esc_cancels(tmp_path):
    """Similarity Map on a 41K-vertex sphere with a window (Xvfb): invoke works in a thread with
    progress, registers for redo, and Esc during a long run (eta3 20) writes nothing."""
    out = run_windowed(tmp_path, SIMILARITY_MODAL_SCRIPT)
    assert out["first"] == ['RUNNING_MODAL'] and out["mapped"]
    assert out["last_operator"] == "DGMESH_OT_similarity_map"
    assert out["second"] == ['RUNNING_MODAL'] and out["no_map_after_esc"]


def _noisy_grid(name, x=0.0):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=10, y_subdivisions=10, size=2, location=(x, 0, 0))
    obj = bpy.context.object
    obj.name = name
    rng = np.random.default_rng(1)
    co = coords(obj.data).copy()
    co[:, 2] = 0.05 * rng.standard_normal(len(co)) + 0.3 * np.exp(-4 * (co[:, 0] ** 2 + co[:, 1] ** 2))
    obj.data.vertices.foreach_set("co", co.astype(np.float32).ravel())
    obj.data.update()
    return obj


def test_mirror_half_stays_welded_at_the_plane():
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = _noisy_grid("Half")
    keep_mirror_half(obj)
    seam = np.flatnonzero(np.abs(coords(obj.data)[:, 0]) < 1e-6)
    assert len(seam) == 11
    before = coords(obj.data).copy()
    assert denoise() == {'FINISHED'}
    co = coords(obj.data)
    assert np.abs(co[seam, 0]).max() < 1e-6  # on the plane: the Mirror modifier still welds them
    assert np.abs(co - before).max() > 1e-3  # and the mesh was denoised


def test_edit_mode_object_without_selection_is_skipped():
    """Several objects in Edit mode: one with nothing selected is left alone, not an error."""
    bpy.ops.wm.read_homefile(use_empty=True)
    a, b = _noisy_grid("A"), _noisy_grid("B", x=3.0)
    for o in (a, b):
        o.select_set(True)
    bpy.context.view_layer.objects.active = a
    bpy.ops.object.mode_set(mode='EDIT')
    import bmesh
    for o, sel in ((a, True), (b, False)):
        bm = bmesh.from_edit_mesh(o.data)
        for v in bm.verts:
            v.select = sel
        bm.select_flush(sel)
        bmesh.update_edit_mesh(o.data)
    a.update_from_editmode()
    b.update_from_editmode()
    ca, cb = coords(a.data).copy(), coords(b.data).copy()
    assert denoise() == {'FINISHED'}
    bpy.ops.object.mode_set(mode='OBJECT')
    assert not np.array_equal(coords(a.data), ca) and np.array_equal(coords(b.data), cb)


def test_auto_on_a_clean_mesh_changes_nothing_and_says_so(dg, capsys):
    """A noise-free sphere: the automatic mode finds no noise to remove, leaves the vertices alone and its report
    says that nothing ran (it said 'similarity, 0 iterations')."""
    open_fixture("shapes")
    V, F = dg.shapes.icosphere(4, 1.0)
    obj = add_mesh_object("Clean", V, F)
    before = coords(obj.data).copy()
    select("Clean")
    capsys.readouterr()
    assert denoise() == {'FINISHED'}
    out = capsys.readouterr().out
    assert "with nothing (Auto found no noise to remove)" in out and "0 moved" in out, out
    np.testing.assert_array_equal(coords(obj.data), before)
