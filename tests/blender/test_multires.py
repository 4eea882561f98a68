"""dgmesh.multires_preview: control wireframe object, displacement colours, errors change nothing."""

import bpy
import numpy as np
import pytest

from helpers import attribute_array, independent_arrays, mesh_snapshot, open_fixture, run_windowed, select

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
    controls = [o for o in bpy.data.objects if o.get("dgmesh_multires_control_of") == obj]
    assert len(controls) == 1 and len(controls[0].data.polygons) <= 120
    # Also after the mesh object is renamed (the control object points at it, not at its name).
    obj.name = "Ring"
    assert _run(control_faces=100) == {'FINISHED'}
    controls = [o for o in bpy.data.objects if o.get("dgmesh_multires_control_of") == obj]
    assert len(controls) == 1 and len([o for o in bpy.data.objects if o.name.endswith("_control")]) == 1


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


def test_cancel_leaves_mesh_unchanged(capsys):
    from dgmesh.blender import ops_multires

    open_fixture("shapes")
    select("Torus")
    obj = bpy.data.objects["Torus"]
    before = mesh_snapshot(obj.data)
    n_objects = len(bpy.data.objects)
    ops_multires.cancel_event.set()  # what Esc does in the modal run
    assert _run(control_faces=200) == {'CANCELLED'}
    assert "Multires Preview: cancelled, nothing was changed" in capsys.readouterr().out
    assert not ops_multires.cancel_event.is_set()
    assert mesh_snapshot(obj.data) == before
    assert len(bpy.data.objects) == n_objects and "Torus_control" not in bpy.data.objects
    assert _run(control_faces=200) == {'FINISHED'}


def test_esc_midway_stops_the_worker_thread(dg):
    """The operator's native work in the worker thread (jobs.Job, as invoke runs it): an Esc that
    arrives midway (the cancel flag, set here once a third of the build is done) stops the build
    with Cancelled; nothing is returned for finish() to write."""
    from dgmesh.blender import ops_multires
    from dgmesh.blender.jobs import Job

    class EscMidway(Job):
        def progress(self, fraction):
            if fraction > 0.3:
                self.cancelled = True  # modal() sets this on Esc
            return super().progress(fraction)

    V, F = dg.shapes.icosphere(5)
    job = EscMidway(ops_multires.make_work(V, F, control_faces=500)).start()
    assert job.wait(60)
    assert isinstance(job.error, dg.Cancelled) and job.result is None
    assert 0.3 < job.fraction < 1.0
    # Without Esc the same work completes.
    job = Job(ops_multires.make_work(V, F, control_faces=500)).start()
    assert job.wait(60) and job.error is None and job.result[0].n_dense == len(V)


MODAL_SCRIPT = r'''

def setup(subdivisions):
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions)
    return bpy.context.active_object

def done(obj):
    return "dg_multires_magnitude" in obj.data.attributes

def step():
    ph = state["phase"]
    if ph == 0:
        setup(6)
        out["first"] = sorted(invoke('multires_preview', control_faces=1000))
        state["t0"], state["phase"] = time.time(), 1
    elif ph == 1:
        obj = bpy.data.objects["Icosphere"]
        if done(obj) or time.time() - state["t0"] > 60:
            out["finished"] = done(obj) and "Icosphere_control" in bpy.data.objects
            state["phase"] = 2
    elif ph == 2:
        setup(8)  # 163842 vertices: a build of seconds, cancelled midway
        out["second"] = invoke_to_cancel('multires_preview', control_faces=5000)
        state["phase"] = 3
        return 0.0
    elif ph == 3:
        if esc_until_worker_ends():
            state["phase"] = 4
        return 0.3
    else:
        obj = bpy.data.objects["Icosphere"]
        out["unchanged_after_esc"] = not done(obj) and "Icosphere_control" not in bpy.data.objects
        report_and_quit()
        return None
    return 0.2
'''


@pytest.mark.skipif(not __import__("shutil").which("xvfb-run"), reason="needs xvfb-run for a windowed Blender")
def test_interactive_run_is_modal_and_esc_cancels(tmp_path):
    """With a window (Xvfb), invoke builds in a worker thread and finishes on its own; a simulated
    Esc during a long build cancels it and writes nothing (no attributes, no control object)."""
    out = run_windowed(tmp_path, MODAL_SCRIPT, timeout=300)
    assert out["first"] == ['RUNNING_MODAL'] and out["finished"]
    assert out["second"] == ['RUNNING_MODAL'] and out["unchanged_after_esc"]


def test_deleting_the_source_frees_it(tmp_path):
    """The control cage and the crest-line curve point at their object: deleted, it stayed in the
    file (in no scene, kept by the pointer) through save, reload and Purge. The pointers go; the
    cage and the curve stay."""
    open_fixture("shapes")
    select("Torus")
    assert _run(control_faces=200) == {'FINISHED'}
    select("SubdivCube")
    assert bpy.ops.dgmesh.crest_lines('EXEC_DEFAULT', threshold=8.0, create_curves=True) == {'FINISHED'}
    select("Torus", "SubdivCube")
    assert bpy.ops.object.delete() == {'FINISHED'}
    bpy.context.view_layer.update()
    path = str(tmp_path / "deleted.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    assert "Torus" not in bpy.data.objects and "SubdivCube" not in bpy.data.objects
    assert "Torus_control" in bpy.data.objects
    assert "dgmesh_multires_control_of" not in bpy.data.objects["Torus_control"].keys()
    assert any(o.type == 'CURVE' and "Crest Lines" in o.name for o in bpy.data.objects), [(o.name, o.type) for o in bpy.data.objects]


def test_a_control_target_too_small_is_reported(capsys):
    """A torus cannot go down to 4 faces: the preview said nothing about the 22 it kept."""
    open_fixture("shapes")
    select("Torus")
    assert _run(control_faces=4) == {'FINISHED'}
    out = capsys.readouterr().out
    assert "more than the 4 asked" in out
