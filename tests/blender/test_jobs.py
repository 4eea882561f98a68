"""The worker-thread job behind long operators: result, errors and cancellation."""

import time

import dgmesh
import numpy as np
from dgmesh import shapes
from dgmesh.blender.jobs import Job


def test_job_returns_result():
    job = Job(lambda progress: (progress(0.5), 42)[1]).start()
    assert job.wait(10)
    assert job.result == 42 and job.error is None and job.fraction == 0.5


def test_job_keeps_exceptions_for_the_main_thread():
    def work(progress):
        raise dgmesh.MeshError("bad mesh")

    job = Job(work).start()
    assert job.wait(10)
    assert isinstance(job.error, dgmesh.MeshError)


def test_cancel_flag_stops_a_progress_driven_computation():
    # The callback returns False once cancelled; a dgmesh function turns that into Cancelled.
    def work(progress):
        for i in range(1000):
            if not progress(i / 1000):
                raise dgmesh.Cancelled("cancelled")
            time.sleep(0.001)
        return "finished"

    job = Job(work).start()
    time.sleep(0.05)
    job.cancelled = True
    assert job.wait(10)
    assert isinstance(job.error, dgmesh.Cancelled) and job.result is None


def test_native_call_runs_in_worker_thread():
    V, F = shapes.icosphere(3)
    job = Job(lambda progress: dgmesh.curvature(V, F).mean).start()
    assert job.wait(30)
    assert np.allclose(job.result, 1.0)


def test_a_mesh_edited_while_the_job_runs_is_not_written_over():
    """The UI stays usable while a job runs: a selected mesh edited (or deleted) before the job ends
    keeps the edit, and the operator reports that nothing was written (the result had overwritten
    the edit)."""
    import types

    import bpy
    from dgmesh.blender import jobs

    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3)
    obj = bpy.context.object
    finished = []

    class Op(jobs.NativeJobOperator):
        bl_label = "Test"

        def __init__(self):
            self.reports = []

        def report(self, kind, msg):
            self.reports.append((kind, msg))

        def prepare(self, context):
            return lambda progress: "result"

        def finish(self, context, result):
            finished.append(result)
            return {'FINISHED'}

    wm = types.SimpleNamespace(progress_update=lambda v: None, progress_end=lambda: None,
                               event_timer_remove=lambda t: None)
    ctx = types.SimpleNamespace(window_manager=wm, workspace=types.SimpleNamespace(status_text_set=lambda t: None))
    timer = types.SimpleNamespace(type='TIMER')

    def run(edit):
        op = Op()
        op._meshes = jobs.mesh_signatures(bpy.context)  # what invoke records
        op._job = Job(op.prepare(bpy.context)).start()
        op._timer = None
        assert op._job.wait(10)
        edit()
        return op, op.modal(ctx, timer)

    op, ret = run(lambda: None)
    assert ret == {'FINISHED'} and finished == ["result"]

    def move():
        obj.data.vertices[0].co.x += 0.5

    op, ret = run(move)
    assert ret == {'CANCELLED'} and finished == ["result"]
    assert "changed while it was running" in op.reports[-1][1]
    op, ret = run(lambda: bpy.data.objects.remove(obj))
    assert ret == {'CANCELLED'} and len(finished) == 1
