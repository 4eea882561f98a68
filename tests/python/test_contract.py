"""One contract per capability: the numpy API's keyword defaults are the C++ options' defaults
(bound from the C++ initialisers), enum keywords accept exactly the C++ enum's names, and every
bound options and result class lists its fields."""

import inspect
import sys

import numpy as np
import pytest

import dgmesh
from dgmesh import _native

# numpy function (a dotted name for a method) -> (its options object, or a tuple of them for a
# function taking several, {keyword: field} where the names differ). Every keyword that names a
# field must default to the field's value (None: "the options' own default").
CONTRACT = {
    "denoise": (lambda: _native.DenoiseOptions(), {}),
    "similarity": (lambda: _native.SimilarityOptions(), {}),
    "estimate_noise": (lambda: _native.NoiseOptions(), {}),
    "unwrap": (lambda: _native.UnwrapOptions(), {}),
    "unwrap_charts": (lambda: _native.UnwrapOptions(), {}),
    "uv_metrics": (lambda: _native.UnwrapOptions(), {}),  # zero_area_eps
    "uv_stretch": (lambda: _native.UnwrapOptions(), {}),
    "fair": (lambda: _native.FairOptions(), {}),
    "regularize": (lambda: _native.RegularizeOptions(), {}),
    "remesh": (lambda: _native.RemeshOptions(), {}),
    "remesh_full": (lambda: _native.RemeshOptions(), {}),
    "Multires.build": (lambda: _native.MultiresOptions(), {}),
    "Multires.bind": (lambda: _native.MultiresOptions(), {}),
    "curvature_derivatives": (lambda: _native.DerivativeOptions(), {}),
    "crest_lines": (lambda: (_native.DerivativeOptions(), _native.CrestOptions()), {}),
    "decimate": (lambda: (_native.DecimateOptions(), _native.decimate_feature_defaults()), {}),
    "segment": (lambda: (_native.SegmentOptions(), _native.segment_feature_defaults()), {}),
    "skeletal_mesh": (lambda: _native.SkeletonOptions(), {}),
    "skeletal.ring_weights": (lambda: _native.RingWeightOptions(), {}),
    "SkeletalRig.bind": (lambda: (_native.SkeletalRigOptions(), _native.SkeletalRigOptions().skeleton),
                         {"fit_iterations": "multires_fit_iterations"}),
    "SkeletalRig.deform": (lambda: _native.SkeletalDeformOptions(), {}),
    "SkeletalRig.deform_control": (lambda: _native.SkeletalDeformOptions(), {}),
}


def _function(name):
    """A public function of dgmesh by its name, or a class's method as "Class.method"."""
    obj = dgmesh
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _fields(options):
    out = {}
    for o in options if isinstance(options, tuple) else (options,):
        out.update(dgmesh.core.fields(o))
    return out


@pytest.mark.parametrize("name", sorted(CONTRACT))
def test_keyword_defaults_are_the_native_defaults(name):
    make, renames = CONTRACT[name]
    options = make()
    fields = _fields(options)
    checked = []
    for param in inspect.signature(_function(name)).parameters.values():
        field = renames.get(param.name, param.name)
        if field not in fields or param.default is inspect.Parameter.empty:
            continue
        checked.append(field)
        expected = fields[field]
        if param.default is None:
            continue  # the options object's own value is used
        if hasattr(type(expected), "__members__"):
            assert param.default == expected.name, (name, param.name)
        else:
            assert param.default == expected and type(param.default) is type(expected), (name, param.name)
    assert checked, f"{name} shares no keyword with {options!r}"
    assert set(renames.values()) <= set(checked), (name, renames)


def _bound_structs():
    return [v for v in vars(_native).values() if isinstance(v, type) and hasattr(v, "__fields__")]


def test_every_bound_struct_lists_fields_and_repr():
    structs = _bound_structs()
    assert any(s.__name__ == "DenoiseOptions" for s in structs)
    for cls in structs:
        obj = cls()
        assert cls.__fields__, cls
        for f in cls.__fields__:
            getattr(obj, f)
        assert repr(obj).startswith(cls.__name__ + "(")
        assert obj == cls()


def test_options_reject_wrong_types_by_name():
    with pytest.raises(dgmesh.MeshError, match="eta1"):
        dgmesh.core.make_options(_native.DenoiseOptions(), eta1="a lot")
    with pytest.raises(dgmesh.MeshError, match="method 'median'.*'similarity', 'bilateral'"):
        dgmesh.core.make_options(_native.DenoiseOptions(), method="median")
    o = dgmesh.core.make_options(_native.DenoiseOptions(), method="BILATERAL", iterations=np.int64(5))
    assert o.method == _native.DenoiseMethod.bilateral and o.iterations == 5


def test_result_arrays_are_views_that_keep_the_result_alive():
    V, F = _native.icosphere(2, 1.0)
    arr = dgmesh.denoise(V, F, iterations=1).vertices
    assert arr.base is not None and arr.flags.writeable
    assert sys.getrefcount(arr.base) >= 2
    del V
    assert np.isfinite(arr).all() and arr.shape == (len(F) // 2 + 2, 3)


def test_fair_scheme_defaults():
    """fair(max_iterations=None) takes the scheme's budget: FairOptions() is the semi-implicit
    scheme's start, the explicit scheme's small steps get more iterations."""
    semi = _native.fair_defaults(_native.FairScheme.semi_implicit)
    assert semi == _native.FairOptions() and semi.scheme == _native.FairScheme.semi_implicit
    explicit = sys.modules["dgmesh.fairing"].defaults("explicit")
    assert explicit.scheme == _native.FairScheme.explicit and explicit.max_iterations > semi.max_iterations
    V, F = _native.icosphere(1, 1.0)
    r = dgmesh.fair(V * np.array([2.0, 1.0, 1.0]), F, scheme="explicit", tolerance=0.0, max_iterations=None)
    assert r.iterations == explicit.max_iterations


def test_results_replace_returns_a_changed_copy():
    V, F = _native.icosphere(2, 1.0)
    r = dgmesh.fair(V, F, max_iterations=2)
    assert r.moved.dtype == bool and r.moved.all() and isinstance(r.level_iterations, np.ndarray)
    moved = r.moved.copy()
    moved[0] = False
    c = r.replace(moved=moved, iterations=7, vertices=r.vertices[::-1])
    assert c.iterations == 7 and not c.moved[0] and r.moved[0] and r.iterations != 7
    assert np.array_equal(c.vertices, r.vertices[::-1]) and np.array_equal(c.faces, r.faces)
    assert c.replace() == c and c != r
    with pytest.raises(TypeError, match="no field 'speed'"):
        r.replace(speed=1)
