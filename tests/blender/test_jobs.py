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
    job = Job(lambda progress: dgmesh.curvature(V, F)["mean"]).start()
    assert job.wait(30)
    assert np.allclose(job.result, 1.0)
