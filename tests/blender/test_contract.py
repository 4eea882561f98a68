"""Operators start from the library's defaults: every property that names a field of the
capability's native options object defaults to the C++ value, and enum properties offer exactly
the C++ enum's members (identifiers in upper case)."""

import bpy
import pytest

from dgmesh import _native

# operator -> (its options object, or a tuple of them for an operator setting several,
# {property: field} where the names differ)
OPERATORS = {
    "denoise": (lambda: _native.DenoiseOptions(), {}),
    "similarity_map": (lambda: _native.SimilarityOptions(), {}),
    "unwrap": (lambda: _native.UnwrapOptions(), {}),
    "fair": (lambda: _native.FairOptions(), {}),
    "regularize": (lambda: _native.RegularizeOptions(), {"strength": "step_scale", "keep_on_surface": "project"}),
    "remesh": (lambda: _native.RemeshOptions(),
               {"relax": "lloyd_iterations", "flips": "flip_3d", "smooth": "smooth_iterations"}),
    "multires_preview": (lambda: _native.MultiresOptions(), {}),
    "crest_lines": (lambda: (_native.DerivativeOptions(), _native.CrestOptions()), {}),
    "decimate_features": (lambda: (_native.DecimateOptions(), _native.decimate_feature_defaults()), {}),
    "segment": (lambda: (_native.SegmentOptions(), _native.segment_feature_defaults()), {}),
    "skeletal_bind": (lambda: (_native.SkeletalRigOptions(), _native.SkeletalDeformOptions()), {}),
}


def _properties(idname):
    return getattr(bpy.ops.dgmesh, idname).get_rna_type().properties


@pytest.mark.parametrize("idname", sorted(OPERATORS))
def test_property_defaults_are_the_native_defaults(idname):
    make, renames = OPERATORS[idname]
    options = make()
    fields = {f: getattr(o, f) for o in (options if isinstance(options, tuple) else (options,))
              for f in type(o).__fields__}
    checked = []
    for prop in _properties(idname):
        field = renames.get(prop.identifier, prop.identifier)
        if field not in fields:
            continue
        checked.append(field)
        value = fields[field]
        if prop.type == 'ENUM':
            assert [i.identifier for i in prop.enum_items] == [m.upper() for m in type(value).__members__], idname
            assert prop.default == value.name.upper(), (idname, prop.identifier)
        elif prop.type == 'FLOAT':
            assert prop.default == pytest.approx(value, rel=1e-6, abs=1e-7), (idname, prop.identifier)
        else:
            assert prop.default == value, (idname, prop.identifier)
    assert checked, f"dgmesh.{idname} shares no property with {options!r}"
    assert set(renames.values()) <= set(checked), (idname, renames)


def test_switching_the_denoise_method_loads_its_native_defaults():
    from dgmesh.blender import ops_denoise

    class Props:
        method = 'BILATERAL'

    props = Props()
    ops_denoise.load_method_defaults(props, None)
    d = _native.denoise_defaults(_native.DenoiseMethod.bilateral)
    assert (props.eta1, props.eta2, props.eta3, props.iterations) == (d.eta1, d.eta2, d.eta3, d.iterations)


def test_unwrap_iterates_to_the_optimum_by_default_as_the_library():
    """UnwrapOptions.iterations is -1 (Uopt) or a step count: the operator's Optimal switch and
    Steps count; Optimal is on exactly when the library's default iterates to the optimum."""
    optimal = _properties("unwrap")["optimal"]
    assert optimal.default == (_native.UnwrapOptions().iterations < 0)


def test_remesh_resample_boundary_defaults_to_the_native_boundary():
    prop = _properties("remesh")["resample_boundary"]
    assert prop.default == (_native.RemeshOptions().boundary == _native.RemeshBoundary.resample)


def test_switching_the_fair_scheme_loads_its_native_iteration_budget():
    from dgmesh.blender import ops_fair

    for scheme in _native.FairScheme.__members__.values():
        class Props:
            pass

        props = Props()
        props.scheme = scheme.name.upper()
        ops_fair.load_scheme_defaults(props, None)
        assert props.max_iterations == _native.fair_defaults(scheme).max_iterations


def test_skeleton_blend_defaults_to_the_native_blend():
    prop = _properties("skeletal_bind")["skeleton_blend"]
    blend = 'DUAL_QUATERNION' if _native.SkeletalDeformOptions().dual_quaternion else 'LINEAR'
    assert prop.default == blend and {i.identifier for i in prop.enum_items} == {'DUAL_QUATERNION', 'LINEAR'}


@pytest.mark.parametrize("idname", ["decimate_features", "segment"])
def test_feature_weight_stops_at_the_native_limit(idname):
    # Beyond the limit the native call refuses the value; the property must not offer it.
    assert _properties(idname)["feature_weight"].hard_max == pytest.approx(_native.MAX_FEATURE_WEIGHT)
