"""Bad values get clear errors naming them, and results are finite (issue #34). test_fuzz.py
checks the same properties on random input; these are the cases found by hand."""

import numpy as np
import pytest

import dgmesh
from dgmesh import shapes


@pytest.fixture(scope="module")
def sphere():
    return shapes.icosphere(1)


# -- every option goes through one check (core.make_options / as_option) ----------------------------
@pytest.mark.parametrize("name, value", [("eta1", [1, 2]), ("eta2", "x"), ("eta3", float("nan")),
                                         ("eta1", float("inf")), ("eta2", 1j), ("eta3", True)])
def test_denoise_float_options_name_themselves(sphere, name, value):
    with pytest.raises(dgmesh.MeshError, match=f"{name} must be a finite number, got"):
        dgmesh.denoise(*sphere, **{name: value})


def test_denoise_none_means_the_default(sphere):
    V, F = sphere
    assert np.allclose(dgmesh.denoise(V, F, eta1=None).vertices, dgmesh.denoise(V, F).vertices)


@pytest.mark.parametrize("name, value", [("tolerance", "x"), ("step_scale", [1.0]), ("max_seconds", "1"),
                                         ("tangential", "no"), ("refine", 2), ("keep_size", [True]),
                                         ("subdivisions", 1.5), ("max_iterations", "10")])
def test_fair_options_name_themselves(sphere, name, value):
    with pytest.raises(dgmesh.MeshError, match=name):
        dgmesh.fair(*sphere, **{name: value})


@pytest.mark.parametrize("value", [-1.0, float("nan"), -float("inf"), float("inf")])
def test_fair_max_seconds_range(sphere, value):
    with pytest.raises(dgmesh.MeshError, match="max_seconds"):
        dgmesh.fair(*sphere, max_seconds=value)


def test_bool_options_take_only_bools(sphere):
    with pytest.raises(dgmesh.MeshError, match="smooth must be True or False, got 'no'"):
        dgmesh.crest_lines(*sphere, smooth="no")
    with pytest.raises(dgmesh.MeshError, match="ridges must be True or False"):
        dgmesh.crest_lines(*sphere, ridges="yes")
    with pytest.raises(dgmesh.MeshError, match="greedy must be True or False"):
        dgmesh.decimate(*sphere, target_faces=20, greedy=[1])
    # numpy bools and 0/1 (Blender's IntProperty-backed flags) count
    dgmesh.curvature_derivatives(*sphere, smooth=np.bool_(False), use_normals=0)


def test_float_options_of_other_functions(sphere):
    V, F = sphere
    with pytest.raises(dgmesh.MeshError, match="min_quality must be a finite number"):
        dgmesh.decimate(V, F, target_faces=20, min_quality="x")
    with pytest.raises(dgmesh.MeshError, match="density must be in"):
        dgmesh.fairing.refine_region(V, F, np.ones(len(F), bool), density=-1)


# -- feature weights beyond the range F(d) can take ----------------------------------------------
@pytest.mark.parametrize("fn", [lambda V, F, w: dgmesh.decimate(V, F, target_faces=20, feature_weight=w),
                                lambda V, F, w: dgmesh.segment(V, F, segments=3, feature_weight=w)])
def test_feature_weight_range(sphere, fn):
    V, F = shapes.torus(1.0, 0.4, 12, 8)
    for w in (1e9, 101.0, -1.0, float("nan")):
        with pytest.raises(dgmesh.MeshError, match="feature_weight"):
            fn(V, F, w)
    fn(V, F, 100.0)  # the top of the range works


# -- saved bind data: tampered values are named ---------------------------------------------------
def test_multires_from_arrays_names_bad_values():
    V, F = shapes.icosphere(2)
    data = dgmesh.Multires.build(V, F, control_faces=20).to_arrays()
    for value in (np.int64(2**40), np.array("x"), 2.5):
        with pytest.raises(dgmesh.MeshError, match="multires data level"):
            dgmesh.Multires.from_arrays({**data, "level": value})
    with pytest.raises(dgmesh.MeshError, match="format_version"):
        dgmesh.Multires.from_arrays({**data, "format_version": np.array("x")})
    dgmesh.Multires.from_arrays({**data, "level": np.array([data["level"]])})  # 1-element arrays: older files


def test_skeletal_rig_from_arrays_names_bad_values():
    V, F = shapes.icosphere(2)
    B = np.tile(np.eye(4), (2, 1, 1))
    B[1, 2, 3] = 0.5
    rig = dgmesh.SkeletalRig.bind(V, F, B)
    for name, value in (("fairing_step", "x"), ("projection", float("nan")), ("dual_quaternion", "no")):
        with pytest.raises(dgmesh.MeshError, match=name):
            rig.deform(B, **{name: value})
    data = rig.to_arrays()
    for key, value in (("frame_regularization", "x"), ("frame_regularization", float("nan")),
                       ("has_multires", "yes"), ("mr_level", 2**40)):
        with pytest.raises(dgmesh.MeshError, match=key):
            dgmesh.SkeletalRig.from_arrays({**data, key: value})
    with pytest.raises(dgmesh.MeshError, match="skeletal data: 'S' has the wrong type"):
        dgmesh.SkeletalRig.from_arrays({**data, "S": np.array(["a", "b"])})
    with pytest.raises(dgmesh.MeshError, match="bind data must be a dict"):
        dgmesh.SkeletalRig.from_arrays([1, 2])


# -- results are finite, or an error says why -----------------------------------------------------
@pytest.mark.parametrize("kw", [{}, {"eta": 1e-300}, {"min_improvement": -1}])
def test_unwrap_metrics_finite_in_every_step(kw):
    V, F = shapes.grid(4, 4)
    r = dgmesh.unwrap(V, F, **kw)
    for step in r.steps:
        for name in type(step.metrics).__fields__:
            assert np.isfinite(getattr(step.metrics, name)), (name, step)
    m = dgmesh.uv_metrics(V, F, r.uv)
    assert m.edge == pytest.approx(r.final.edge) and m.angle == pytest.approx(r.final.angle)


def test_huge_coordinates_are_rejected(sphere):
    V, F = sphere
    with pytest.raises(dgmesh.MeshError, match=r"P: vertex 0 has a coordinate beyond 1e\+50"):
        dgmesh.point_mesh_distance(V * 1e200, V, F)
    with pytest.raises(dgmesh.MeshError, match="V: vertex 0 has a coordinate beyond"):
        dgmesh.curvature(V * 1e60, F)
    d = dgmesh.point_mesh_distance(V * 1e49, V * 1e49, F)
    assert np.isfinite(d).all() and d.max() < 1e40


def test_point_mesh_distance_degenerate_triangle():
    # Two corners coincide: the distance to the segment left (found by test_fuzz: it was NaN).
    V = np.array([[1.0, 0, 0], [1, 0, 0], [0, 0, 1]])
    d = dgmesh.point_mesh_distance([[0.5, 0, 0], [2, 0, 0]], V, [[0, 1, 2]])
    assert d == pytest.approx([0.125 ** 0.5, 1.0])


@pytest.mark.parametrize("text", ["nan 0 0", "0 inf 0", "0 0 -inf"])
def test_read_mesh_rejects_non_finite_coordinates(tmp_path, text):
    path = tmp_path / "m.obj"
    path.write_text(f"v 0 0 0\nv 1 0 0\nv {text}\nf 1 2 3\n")
    with pytest.raises(dgmesh.MeshIOError, match="vertex 2 has a NaN or infinite coordinate"):
        dgmesh.read_mesh(path)


# -- one family of errors ---------------------------------------------------------------------------
def test_every_error_is_a_dgmesh_error():
    for cls in (dgmesh.MeshError, dgmesh.MeshIOError, dgmesh.SolverError, dgmesh.Cancelled, dgmesh.UnwrapChartError):
        assert issubclass(cls, dgmesh.Error), cls
    for cls in (dgmesh.MeshError, dgmesh.MeshIOError, dgmesh.UnwrapChartError):
        assert issubclass(cls, ValueError), cls  # as before: except ValueError still catches them
    with pytest.raises(dgmesh.Error):
        dgmesh.curvature(np.zeros((0, 3)), np.zeros((0, 3), int))


def test_every_exception_class_of_the_package_derives_from_dgmesh_error():
    import importlib
    import inspect
    import pkgutil
    found = []
    for info in pkgutil.walk_packages(dgmesh.__path__, "dgmesh."):
        if info.name.startswith("dgmesh.blender"):  # needs bpy; its exceptions are the operators' own
            continue
        module = importlib.import_module(info.name)
        found += [c for _, c in inspect.getmembers(module, inspect.isclass)
                  if issubclass(c, BaseException) and c.__module__.startswith("dgmesh")]
    assert dgmesh.skeletal_data.BindDataError in found
    assert [c for c in found if not issubclass(c, dgmesh.Error)] == []


def test_gaussian_weights_with_a_tiny_sigma():
    # Found by test_fuzz: sigma^2 underflowed and every weight was 0 / 0.
    from dgmesh.skeletal import gaussian_bone_weights
    P = np.array([[0.0, 0, 0], [0, 0, 1], [0, 0, 0.25]])
    W = gaussian_bone_weights(P, [[0.0, 0, -1], [0, 0, 1]], [[0.0, 0, -0.5], [0, 0, 2]], 1e-300)
    assert np.isfinite(W).all() and W == pytest.approx(np.array([[1, 0], [0, 1], [0.5, 0.5]]))
