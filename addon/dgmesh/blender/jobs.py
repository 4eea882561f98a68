"""Long native computations with progress and Esc to cancel.

An operator that mixes in :class:`NativeJobOperator` splits its work in three:

* ``prepare(context)`` (main thread): read Blender data into numpy and return a callable
  ``work(progress)`` that does the native computation, or None after reporting an error;
* ``work(progress)`` (a worker thread when interactive): numpy and dgmesh calls only, no bpy;
  passes ``progress`` (fraction -> bool) to the dgmesh function, which raises dgmesh.Cancelled
  when it returns False;
* ``finish(context, result)`` (main thread): write the result back and report; returns the
  operator's set.

``execute`` (redo panel, scripts, --background) runs them in a row with the window manager's
progress indicator. ``invoke`` with a window runs ``work`` in a thread and polls it from a modal
timer, so the UI stays responsive, the status bar shows the progress and Esc cancels with the
mesh unchanged (nothing is written before ``finish``). The UI stays usable meanwhile, so a mesh
selected when the job started and edited before it ended (moved vertices, other topology, deleted)
is not written over: the result is dropped with an error.
"""

import hashlib
import threading

import bpy
import numpy as np

from .prefs import api


def item_shares(progress, items, size):
    """(item, its progress callback) for each item, the callback mapping the item's own fraction onto
    its share of ``progress``, shares proportional to ``size(item)`` (one native call per object)."""
    total = float(sum(size(it) for it in items)) or 1.0
    done = 0.0
    for it in items:
        n = size(it)
        yield it, (lambda f, done=done, n=n: progress((done + f * n) / total))
        done += n


class Job:
    """A callable run in a worker thread, with a progress fraction and a cancel flag."""

    def __init__(self, work):
        self.work = work
        self.fraction = 0.0
        self.cancelled = False
        self.result = None
        self.error = None
        self._thread = threading.Thread(target=self._run, daemon=True)

    def progress(self, fraction):
        self.fraction = float(fraction)
        return not self.cancelled

    def _run(self):
        try:
            self.result = self.work(self.progress)
        except BaseException as exc:  # surfaced in the main thread by the operator
            self.error = exc

    def start(self):
        self._thread.start()
        return self

    def wait(self, timeout=None):
        self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def done(self):
        return not self._thread.is_alive()


def _signature(obj):
    """Counts and a hash of the vertex positions (an object in Edit mode synced from its edit-mesh)."""
    if obj.mode == 'EDIT':
        obj.update_from_editmode()
    me = obj.data
    co = np.empty(3 * len(me.vertices), dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return (len(me.vertices), len(me.edges), len(me.loops), len(me.polygons),
            hashlib.blake2b(co.tobytes(), digest_size=16).digest())


def mesh_signatures(context):
    """{object name: signature} of the selected and active mesh objects."""
    objs = {o for o in context.selected_objects if o.type == 'MESH'}
    if context.active_object is not None and context.active_object.type == 'MESH':
        objs.add(context.active_object)
    return {o.name: _signature(o) for o in objs}


def changed_meshes(before):
    """Names of the objects of ``before`` (mesh_signatures) deleted or edited since."""
    out = []
    for name, sig in before.items():
        o = bpy.data.objects.get(name)
        if o is None or o.type != 'MESH' or _signature(o) != sig:
            out.append(name)
    return out


class NativeJobOperator:
    """Mixin for bpy.types.Operator subclasses; see the module docstring."""

    def prepare(self, context):  # pragma: no cover - overridden
        raise NotImplementedError

    def finish(self, context, result):  # pragma: no cover - overridden
        raise NotImplementedError

    def report_failure(self, exc):
        dg = api()
        if isinstance(exc, dg.Cancelled):
            self.report({'WARNING'}, f"{self.bl_label}: cancelled, nothing was changed")
        elif isinstance(exc, dg.MeshError):
            self.report({'ERROR'}, f"{self.bl_label}: {exc}")
        else:
            self.report({'ERROR'}, f"{self.bl_label}: internal error: {type(exc).__name__}: {exc}")
        return {'CANCELLED'}

    def execute(self, context):
        work = self.prepare(context)
        if work is None:
            return {'CANCELLED'}
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        try:
            result = work(lambda f: (wm.progress_update(int(1000 * f)), True)[1])
        except Exception as exc:
            return self.report_failure(exc)
        finally:
            wm.progress_end()
        return self.finish(context, result)

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        work = self.prepare(context)
        if work is None:
            return {'CANCELLED'}
        wm = context.window_manager
        self._meshes = mesh_signatures(context)
        self._job = Job(work).start()
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        context.workspace.status_text_set(f"{self.bl_label}: running (Esc to cancel)")
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        job = self._job
        if event.type == 'ESC':
            job.cancelled = True
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'} if event.type == 'ESC' else {'PASS_THROUGH'}
        wm = context.window_manager
        wm.progress_update(int(1000 * job.fraction))
        if not job.done:
            return {'RUNNING_MODAL'}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        if job.error is not None:
            return self.report_failure(job.error)
        changed = changed_meshes(self._meshes)
        if changed:
            self.report({'ERROR'}, f"{self.bl_label}: {', '.join(map(repr, changed[:3]))} changed while it was "
                        "running (edited, undone or deleted): nothing was written; run it again")
            return {'CANCELLED'}
        return self.finish(context, job.result)
