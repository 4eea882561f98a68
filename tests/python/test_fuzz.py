"""Property-based fuzzing of every public function of dgmesh (issue #34).

Random meshes (valid ones and broken ones: NaN, inf, huge or tiny coordinates, indices out of
range, degenerate, duplicate or flipped faces, loose vertices, empty, wrong shapes and dtypes) and
random option values of every type (good ones, out of range ones and ones of the wrong type) go to
each function in a child process (fuzz_worker.py), so a segfault or an abort fails the case that
caused it instead of the test run. Acceptable: a result whose numbers are finite, or a dgmesh.Error
/ ValueError / TypeError with a message of its own; an option of the wrong type must be named.

The default run is bounded (about two minutes on two cores); ``DGMESH_FUZZ=long`` runs many more
examples (see DEVELOPERS.md); ``DGMESH_FUZZ_SEED=n`` sets the long run's seed (the default run is
derandomized: the same examples every time).
"""

import inspect
import os
import pickle
import select
import signal
import struct
import subprocess
import sys
import typing

import numpy as np
import pytest

from hypothesis import HealthCheck, given, seed, settings  # python3-hypothesis (scripts/deps.sh installs it)
from hypothesis import strategies as st

import dgmesh

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fuzz_worker import BASES, CALLS, MUTATIONS, VALID  # noqa: E402

LONG = os.environ.get("DGMESH_FUZZ") == "long"
SEED = os.environ.get("DGMESH_FUZZ_SEED")
settings.register_profile("dgmesh-fuzz", max_examples=1000, deadline=None, database=None, derandomize=True,
                          suppress_health_check=list(HealthCheck), print_blob=False)
settings.register_profile("dgmesh-fuzz-long", max_examples=10000, deadline=None, database=None,
                          suppress_health_check=list(HealthCheck))
PROFILE = settings.get_profile("dgmesh-fuzz-long" if LONG else "dgmesh-fuzz")
CASE_TIMEOUT = 60.0  # seconds; a longer case is reported as a hang

# The function each call's options are read from (keyword arguments with defaults), and the
# arguments some calls require.
FUNCS = {
    "validate": dgmesh.validate, "denoise": dgmesh.denoise, "denoise_points": dgmesh.denoise,
    "similarity": dgmesh.similarity, "estimate_noise": dgmesh.estimate_noise,
    "estimate_noise_points": dgmesh.estimate_noise, "crest_lines": dgmesh.crest_lines,
    "curvature_derivatives": dgmesh.curvature_derivatives, "decimate": dgmesh.decimate, "segment": dgmesh.segment,
    "fair": dgmesh.fair, "regularize": dgmesh.regularize, "unwrap": dgmesh.unwrap, "unwrap_charts": dgmesh.unwrap_charts,
    "auto_unwrap": dgmesh.auto_unwrap,
    "uv_metrics": dgmesh.uv_metrics, "uv_stretch": dgmesh.uv_stretch, "skeletal_mesh": dgmesh.skeletal_mesh,
    "point_mesh_distance": dgmesh.point_mesh_distance, "remesh": dgmesh.remesh, "remesh_full": dgmesh.remesh_full,
    "multires": dgmesh.Multires.build, "skeletal_rig": dgmesh.SkeletalRig.bind,
    "loop_subdivide": dgmesh.shapes.loop_subdivide, "icosphere": dgmesh.shapes.icosphere, "grid": dgmesh.shapes.grid,
    "torus": dgmesh.shapes.torus,
}
REQUIRED = {"similarity": ("vertex",), "decimate": ("target_faces",), "remesh": ("target_vertices",),
            "remesh_full": ("target_vertices",), "icosphere": ("level",), "grid": ("nx", "ny"),
            "torus": ("R", "r", "nu", "nv")}
SHAPES = {"icosphere", "grid", "torus"}  # their parameters are positional
NOT_OPTIONS = {"progress", "mask", "faces", "groups", "crest_lines", "locked", "planes", "uv_faces", "normals", "out",
               "bone_heads", "bone_tails", "weights"}
# Good values of integer options where small integers would all be out of range or slow.
GOOD_INTS = {"resolution": [16, 24, 40], "target_vertices": [4, 12, 40], "target_faces": [0, 4, 12, 40],
             "control_faces": [4, 8, 30], "segments": [1, 2, 5], "vertex": [0, 1, 5, 41],
             "multires_level": [0, 1, 2], "level": [1, 2], "levels": [0, 1, 2], "nx": [1, 2, 7],
             "ny": [1, 3], "nu": [3, 5], "nv": [3, 4], "charts": [1, 2, 8], "max_charts": [1, 4, 40]}


def _kind(p: inspect.Parameter):
    """('bool' | 'int' | 'float' | 'enum', enum names) of an option, or None for other parameters."""
    d, ann = p.default, p.annotation
    if isinstance(d, bool):
        return "bool", None
    if isinstance(d, int):
        return "int", None
    if isinstance(d, float):
        return "float", None
    names = set()
    for a in typing.get_args(ann) or (ann,):
        if hasattr(a, "__members__"):
            names |= set(a.__members__)
    if names:
        return "enum", sorted(names)
    if isinstance(d, str):  # a choice of plain strings (similarity's mode, uv_stretch's per)
        return "str", [d]
    text = str(ann)
    if (d is None or d is inspect.Parameter.empty) and text == "<class 'float'>":
        return "float", None
    if d is None and "float" in text:
        return "float", None
    if (d is None or d is inspect.Parameter.empty) and "int" in text and "ArrayLike" not in text and "Union" not in text:
        return "int", None
    return None


def options_of(call):
    f = FUNCS.get(call)
    if f is None:
        return {}
    out = {}
    for p in inspect.signature(f).parameters.values():
        if p.name in NOT_OPTIONS or (p.kind is not p.KEYWORD_ONLY and call not in SHAPES
                                     and p.name not in ("vertex", "levels", "allow_loose_vertices")):
            continue
        k = _kind(p)
        if k is not None:
            out[p.name] = k
    return out


OPTIONS = {call: options_of(call) for call in CALLS}

# Values of the wrong type (or not finite) per kind: the error must name the option.
BAD = {
    "bool": ["yes", 2, [True], 0.5],
    "int": ["x", 2.5, [1], True, 2**40, -(2**40), float("nan")],
    "float": ["x", [1.0, 2.0], float("nan"), float("inf"), -float("inf"), 1j, True],
    "enum": ["bogus", 7, [1]],
    "str": ["bogus", 7],
}


def good_value(kind, names, name):
    if kind == "bool":
        return st.sampled_from([True, False, 0, 1, np.bool_(True)])
    if kind == "int":
        return st.sampled_from(GOOD_INTS.get(name, [-1, 0, 1, 2, 3, 8])) | st.just(np.int64(1))
    if kind == "float":
        return (st.floats(-2.0, 10.0, allow_nan=False) | st.sampled_from([0.0, 1e-300, 1e300, -1e300, 0.5])
                | st.just(np.float32(0.5)))
    if kind == "str":
        return st.sampled_from(names)
    return st.sampled_from(names) | st.sampled_from([n.upper() for n in names])


@st.composite
def option_values(draw, call):
    """(kwargs, named): a few options set, at most one of them to a value that must be named."""
    opts = OPTIONS[call]
    required = REQUIRED.get(call, ())
    chosen = set(required) | set(draw(st.lists(st.sampled_from(sorted(opts)), max_size=3) if opts else st.just([])))
    bad = draw(st.sampled_from(sorted(chosen))) if chosen and draw(st.integers(0, 3)) == 0 else None
    kw, named = {}, None
    for name in sorted(chosen):
        kind, names = opts.get(name, ("int", None))
        if name == bad:
            kw[name] = draw(st.sampled_from(BAD[kind]))
            named = name
        else:
            kw[name] = draw(good_value(kind, names, name))
    return kw, named


@st.composite
def meshes(draw):
    """A mesh as its recipe (built in the child by fuzz_worker.build_mesh, so a failing example
    prints short): (base, mutation, vertex, face, column, number)."""
    base = draw(st.sampled_from(sorted(BASES)))
    mutation = draw(st.sampled_from(["none", "noise"]) | st.sampled_from(MUTATIONS))  # half of them valid
    return (base, mutation, draw(st.integers(0, 50)), draw(st.integers(0, 100)), draw(st.integers(0, 2)),
            draw(st.sampled_from([0, 1, 2, 2**31 - 1, 2**16])))


class Worker:
    """The child process running the cases (fuzz_worker.py), restarted after a crash."""

    def __init__(self):
        self.proc = None

    def start(self):
        self.proc = subprocess.Popen([sys.executable, os.path.join(HERE, "fuzz_worker.py")], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, env=dict(os.environ, OMP_NUM_THREADS="1"))

    def stop(self):
        if self.proc is not None:
            if self.proc.poll() is None:
                self.proc.kill()
            self.proc.wait()
            self.proc = None

    def run(self, case):
        """The worker's verdict on one case (None: acceptable), or a sentence saying it crashed or hung."""
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        data = pickle.dumps(case)
        try:
            self.proc.stdin.write(struct.pack("<Q", len(data)) + data)
            self.proc.stdin.flush()
            ready, _, _ = select.select([self.proc.stdout], [], [], CASE_TIMEOUT)
            if not ready:
                self.stop()
                return f"hung (no answer in {CASE_TIMEOUT:g} s)"
            head = self.proc.stdout.read(8)
            if len(head) == 8:
                return pickle.loads(self.proc.stdout.read(struct.unpack("<Q", head)[0]))
        except BrokenPipeError:
            pass
        code = self.proc.wait()
        self.proc = None
        how = signal.Signals(-code).name if code < 0 else f"exit status {code}"
        return f"the process died ({how})"


@pytest.fixture(scope="module")
def worker():
    w = Worker()
    yield w
    w.stop()


@pytest.mark.parametrize("call", sorted(CALLS))
def test_fuzz(call, worker):
    @PROFILE
    @given(mesh=meshes(), options=option_values(call))
    def check(mesh, options):
        kw, named = options
        valid = mesh[0] != "empty" and mesh[1] in VALID
        problem = worker.run((call, mesh, kw, named if valid else None))
        assert problem is None, f"{call}({mesh}, **{kw!r}): {problem}"

    (seed(int(SEED))(check) if SEED else check)()


def test_worker_reports_a_crash(worker):
    # The harness itself: a case that kills the child is a failure naming it, and the next case
    # runs in a new child.
    assert "died (SIGABRT)" in worker.run(("crash", None, {}, None))
    assert worker.run(("curvature", ("icosphere", "none", 0, 0, 0, 0), {}, None)) is None


# Public functions without a call of their own: presets and the thread count take no mesh; files
# are fuzzed as the write/read round trips "obj", "off" and "ply".
NOT_FUZZED = {"decimate_feature_defaults", "segment_feature_defaults", "num_threads", "set_num_threads",
              "read_mesh", "write_mesh"}


def test_every_public_function_is_fuzzed():
    public = {n for n in dgmesh.__all__ if callable(getattr(dgmesh, n)) and not inspect.isclass(getattr(dgmesh, n))}
    assert public - set(CALLS) - NOT_FUZZED == set(), "add the new function to fuzz_worker.CALLS and FUNCS"
    assert {"obj", "off", "ply"} <= set(CALLS)
