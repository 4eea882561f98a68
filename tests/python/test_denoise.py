"""dgmesh.denoise / dgmesh.similarity: the numpy API of thesis chapter 2."""

from pathlib import Path

import numpy as np
import pytest

import dgmesh
from dgmesh import shapes
from dgmesh.denoising import residual_entropy
from test_noise_estimate import graph

CGAL = Path(__file__).resolve().parents[2] / ".cache" / "cgal-data" / "data" / "meshes"


def edge_length(V, F):
    return np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2).mean()


def face_normals(V, F):
    c = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    return c / np.linalg.norm(c, axis=1)[:, None]


def normal_error_deg(A, B, F):
    cos = np.clip(np.einsum("ij,ij->i", face_normals(A, F), face_normals(B, F)), -1, 1)
    return np.degrees(np.arccos(cos))


def noisy(V, F, level, seed=0):
    """Gaussian noise of deviation level * e along the clean vertex normals."""
    N = dgmesh.curvature(V, F).normals
    rng = np.random.default_rng(seed)
    return V + N * rng.normal(0.0, level * edge_length(V, F), (len(V), 1))


@pytest.fixture(scope="module")
def sphere():
    V, F = shapes.icosphere(3, 1.0)
    return V, F, noisy(V, F, 0.2, seed=1)


def test_result_fields_and_sphere_roundness(sphere):
    V, F, Vn = sphere
    r = dgmesh.denoise(Vn, F, automatic=False)  # the thesis's setting
    assert isinstance(r, dgmesh.DenoiseResult)
    assert r.vertices.shape == V.shape and r.vertices.dtype == np.float64
    assert r.residual.shape == (len(V),)
    assert np.allclose(r.residual, np.linalg.norm(r.vertices - Vn, axis=1))
    assert r.iterations == 3
    assert 0 < r.residual_entropy < np.log2(65)
    assert r.residual_entropy == pytest.approx(residual_entropy(r.residual), abs=1e-12)
    rad0, rad = np.linalg.norm(Vn, axis=1), np.linalg.norm(r.vertices, axis=1)
    assert rad.std() < rad0.std() / 3
    assert abs(rad.mean() - 1) < 0.05
    # The automatic setting smooths less here (measured radius deviation 0.0114 against 0.0287 noisy).
    auto = np.linalg.norm(dgmesh.denoise(Vn, F).vertices, axis=1)
    assert auto.std() < rad0.std() / 2 and abs(auto.mean() - 1) < 0.05


def test_inputs_are_not_modified_and_other_dtypes_work(sphere):
    V, F, Vn = sphere
    before = Vn.copy()
    a = dgmesh.denoise(Vn, F)
    assert np.array_equal(Vn, before)
    b = dgmesh.denoise(Vn.tolist(), F.astype(np.int64))
    assert np.array_equal(a.vertices, b.vertices)
    c = dgmesh.denoise(np.asfortranarray(Vn), F)
    assert np.array_equal(a.vertices, c.vertices)


def test_method_defaults_and_explicit_etas(sphere):
    V, F, Vn = sphere
    bil = dgmesh.denoise(Vn, F, method="bilateral", automatic=False)
    explicit = dgmesh.denoise(Vn, F, method="bilateral", eta1=0.25, eta2=1.0, eta3=1.0, iterations=3)
    assert np.array_equal(bil.vertices, explicit.vertices)
    sim = dgmesh.denoise(Vn, F, eta1=0.4, eta2=1.0, eta3=0.75, iterations=3)
    assert np.array_equal(sim.vertices, dgmesh.denoise(Vn, F, automatic=False).vertices)
    assert not np.allclose(sim.vertices, bil.vertices)
    one = dgmesh.denoise(Vn, F, iterations=1)
    assert np.linalg.norm(one.residual) < np.linalg.norm(sim.residual)


def test_plane_returns_to_plane():
    V, F = shapes.grid(30, 30)
    e = edge_length(V, F)
    rng = np.random.default_rng(2)
    Vn = V.copy()
    Vn[:, 2] += rng.normal(0, 0.2 * e, len(V))
    r = dgmesh.denoise(Vn, F)
    inner = np.all((V[:, :2] > 0.1) & (V[:, :2] < 0.9), axis=1)
    assert np.sqrt(np.mean(r.vertices[inner, 2] ** 2)) < 0.06 * e


def test_soup_stays_crack_free(sphere):
    V, F, Vn = sphere
    Vs = Vn[F].reshape(-1, 3)
    Fs = np.arange(len(Vs), dtype=np.int32).reshape(-1, 3)
    r = dgmesh.denoise(Vs, Fs)
    assert r.welded == len(Vs) - len(V)
    out = r.vertices.reshape(-1, 3, 3)
    # Every copy of an original vertex lands on the same point, the welded mesh's result.
    ref = dgmesh.denoise(Vn, F).vertices
    assert np.abs(out - ref[F]).max() < 1e-9
    copies = {}
    for f in range(len(F)):
        for k in range(3):
            copies.setdefault(F[f, k], []).append(out[f, k])
    assert max(np.ptp(np.array(c), axis=0).max() for c in copies.values()) == 0.0


def test_mask_keeps_vertices_fixed(sphere):
    V, F, Vn = sphere
    mask = Vn[:, 0] < 0
    r = dgmesh.denoise(Vn, F, mask=mask)
    assert np.array_equal(r.vertices[~mask], Vn[~mask])
    assert (r.residual[mask] > 0).mean() > 0.9
    # Integer masks are accepted too.
    r2 = dgmesh.denoise(Vn, F, mask=mask.astype(np.int8))
    assert np.array_equal(r.vertices, r2.vertices)


def test_point_cloud_needs_normals_and_is_denoised():
    V, F = shapes.icosphere(4, 1.0)
    Vn = noisy(V, F, 0.2, seed=4)
    with pytest.raises(dgmesh.MeshError, match="normals"):
        dgmesh.denoise(Vn)
    r = dgmesh.denoise(Vn, None, normals=V * 3.0)  # normals need not be unit
    rad0, rad = np.linalg.norm(Vn, axis=1), np.linalg.norm(r.vertices, axis=1)
    assert rad.std() < rad0.std() / 3
    assert abs(rad.mean() - 1) < 0.03


def test_bad_input_raises_mesh_error(sphere):
    V, F, Vn = sphere
    bad = Vn.copy()
    bad[7, 2] = np.nan
    with pytest.raises(dgmesh.MeshError, match="non-finite"):
        dgmesh.denoise(bad, F)
    assert isinstance(dgmesh.MeshError("x"), ValueError)
    with pytest.raises(dgmesh.MeshError, match="mask"):
        dgmesh.denoise(Vn, F, mask=np.ones(3, bool))
    with pytest.raises(dgmesh.MeshError, match="method"):
        dgmesh.denoise(Vn, F, method="median")
    with pytest.raises(dgmesh.MeshError, match="iterations"):
        dgmesh.denoise(Vn, F, iterations=1.5)
    with pytest.raises(dgmesh.MeshError, match="eta1"):
        dgmesh.denoise(Vn, F, eta1=0)
    with pytest.raises(dgmesh.MeshError, match="out of range"):
        dgmesh.denoise(Vn, F + len(Vn))
    with pytest.raises(dgmesh.MeshError):
        dgmesh.denoise(Vn[:, :2], F)
    with pytest.raises(dgmesh.MeshError, match="positive area"):
        dgmesh.denoise(np.zeros_like(Vn), F)
    with pytest.raises(dgmesh.MeshError, match="rows"):
        dgmesh.denoise(Vn, None, normals=Vn[:10])


def test_progress_and_cancel(sphere):
    V, F, Vn = sphere
    seen = []
    dgmesh.denoise(Vn, F, progress=lambda f: seen.append(f))
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    before = Vn.copy()
    with pytest.raises(dgmesh.Cancelled):
        dgmesh.denoise(Vn, F, progress=lambda f: False)
    assert np.array_equal(Vn, before)


def test_similarity_map():
    V, F = shapes.icosphere(3, 1.0)
    w = dgmesh.similarity(V, F, 10)
    assert w.shape == (len(V),) and w[10] == pytest.approx(1.0)
    # Every patch of a sphere has the same shape: all similar (the icosphere is not perfectly
    # uniform, hence not exactly 1).
    assert w.min() > 0.5
    with pytest.raises(dgmesh.MeshError, match="mode"):
        dgmesh.similarity(V, F, 10, mode="other")
    # The filter's own weights vanish on the far side.
    wf = dgmesh.similarity(V, F, 10, mode="filter")
    far = V @ V[10] < -0.5
    assert wf[far].max() < 1e-6 and wf[10] == pytest.approx(1.0)
    with pytest.raises(dgmesh.MeshError, match="out of range"):
        dgmesh.similarity(V, F, len(V))
    wp = dgmesh.similarity(V, None, 10, normals=V)
    assert wp[10] == pytest.approx(1.0) and wp.min() > 0.3


@pytest.mark.skipif(not (CGAL / "fandisk.off").exists(), reason="CGAL data not unpacked (scripts/cgal_data.sh)")
def test_similarity_map_progress_and_cancel():
    """Similarity Map reports progress over blocks of vertices (the add-on shows it and Esc cancels);
    the weights are the same with or without a callback, for meshes and point clouds."""
    V, F = shapes.icosphere(5, 1.0)  # 10242 vertices: several blocks of 2048
    w0 = dgmesh.similarity(V, F, 10)
    seen = []
    w = dgmesh.similarity(V, F, 10, progress=lambda f: seen.append(f))
    assert np.array_equal(w, w0)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    with pytest.raises(dgmesh.Cancelled):
        dgmesh.similarity(V, F, 10, progress=lambda f: f == 0.0)  # cancels at the first block
    seen = []
    wp = dgmesh.similarity(V, None, 10, V, progress=lambda f: seen.append(f))
    assert wp[10] == pytest.approx(1.0) and seen[-1] == 1.0
    with pytest.raises(dgmesh.Cancelled):
        dgmesh.similarity(V, None, 10, V, progress=lambda f: False)


def test_fandisk_similarity_beats_bilateral():
    """The thesis's model: noise of 0.2 e along the normals (fixed seed)."""
    V, F = dgmesh.read_mesh(CGAL / "fandisk.off")
    Vn = noisy(V, F, 0.2, seed=1)
    noisy_err = normal_error_deg(Vn, V, F).mean()
    sim = normal_error_deg(dgmesh.denoise(Vn, F).vertices, V, F).mean()
    bil = normal_error_deg(dgmesh.denoise(Vn, F, method="bilateral").vertices, V, F).mean()
    # Measured: noisy 20.2, similarity 3.3, bilateral 6.4 degrees.
    assert noisy_err > 15
    assert sim < 4.0
    assert sim < 0.7 * bil


# ---- automatic parameters (issue #32) ------------------------------------------------------------

AUTO_SHAPES = {
    "icosphere": lambda: shapes.icosphere(4, 1.0),
    "torus": lambda: shapes.torus(1.0, 0.35, 96, 40),
    "graph": graph,
    "rounded_cube": lambda: shapes.rounded_cube(16, 0.3),
}
for _name in ("fandisk", "homer", "elephant", "camel", "lion-head"):
    if (CGAL / f"{_name}.off").exists():
        AUTO_SHAPES[_name] = lambda _name=_name: dgmesh.read_mesh(CGAL / f"{_name}.off")


@pytest.fixture(scope="module", params=sorted(AUTO_SHAPES))
def auto_shape(request):
    V, F = AUTO_SHAPES[request.param]()
    return request.param, np.asarray(V, dtype=np.float64), np.asarray(F)


def test_default_lowers_the_normal_error(auto_shape):
    name, V, F = auto_shape
    e = edge_length(V, F)
    for level, seed in ((0.1, 21), (0.3, 22)):
        iso = V + np.random.default_rng(seed + 100).normal(0.0, level * e, V.shape)
        for kind, Vn in (("normal", noisy(V, F, level, seed=seed)), ("isotropic", iso)):
            before = normal_error_deg(Vn, V, F).mean()
            r = dgmesh.denoise(Vn, F)
            after = normal_error_deg(r.vertices, V, F).mean()
            assert after < before, f"{name} at {level} e {kind}: {before:.2f} -> {after:.2f} degrees"


def test_default_leaves_noise_free_input_nearly_unchanged(auto_shape):
    name, V, F = auto_shape
    r = dgmesh.denoise(V, F)
    assert normal_error_deg(r.vertices, V, F).mean() < 0.5, name
    if name in ("camel", "lion-head"):
        # Scans where the filter itself moved the noise-free mesh (3.0 and 0.9 degrees): the rule
        # asks for no smoothing step, so nothing runs.
        assert r.options.smoothing_steps == 0 and r.iterations == 0
        assert np.array_equal(r.vertices, V)


def jittered_rounded_cube(jitter, seed):
    """A clean, coarse, irregularly sampled shape with rounded edges: icosphere(2) (162 vertices)
    jittered by `jitter` edge lengths, then put back on the superellipsoid x^8 + y^8 + z^8 = 1 by
    radial projection (every vertex on the surface, none where a regular mesh would put it)."""
    V, F = shapes.icosphere(2, 1.0)
    V = V + np.random.default_rng(seed).normal(0.0, jitter * edge_length(V, F), V.shape)
    V /= np.linalg.norm(V, axis=1)[:, None]
    return V / ((V**8).sum(axis=1) ** 0.125)[:, None], np.asarray(F)


CLEAN_SCANS = [n for n in ("cow", "bull", "ChineseDragon-10kv") if (CGAL / f"{n}.off").exists()]


@pytest.mark.parametrize("jitter,seed", [(0.0, 3), (0.15, 3), (0.3, 3), (0.15, 4)])
def test_default_leaves_a_clean_coarse_feature_bearing_shape(jitter, seed):
    # Its sampling reads as noise (sigma 0.09-0.11 e, as the noise-free CGAL scans' 0.07-0.10) with
    # much shape detail (0.19-0.22 e). The session-22 rule asked for a Taubin step (one step moves it
    # by 3.4-13.1 degrees); the rule's floor (sigma below min(0.9 detail, 0.1 e) is the shape's) leaves
    # it alone, and it still denoises the same shape with noise. Coarser still (x^10 + ...: sigma
    # 0.11-0.14 e) it is moved again (bench/notes/denoise.md).
    V, F = jittered_rounded_cube(jitter, seed)
    r = dgmesh.denoise(V, F)
    assert normal_error_deg(r.vertices, V, F).mean() < 0.5, (r.noise.sigma, r.noise.detail, r.options.smoothing_steps)
    if jitter > 0.2:
        # So irregular that no Taubin count helps much under 0.1 e of noise (measured: 16.39 degrees
        # noisy, best 16.08 at 1 step, 18.04 at the rule's 4): only the noise-free case is checked.
        return
    for level in (0.1, 0.3):
        Vn = noisy(V, F, level, seed=seed + 10)
        before = normal_error_deg(Vn, V, F).mean()
        after = normal_error_deg(dgmesh.denoise(Vn, F).vertices, V, F).mean()
        assert after < before, f"{level} e: {before:.2f} -> {after:.2f} degrees"


@pytest.mark.parametrize("name", CLEAN_SCANS)
def test_default_leaves_noise_free_coarse_scans(name):
    # Decimated CGAL scans (2904-10000 vertices) that the session-22 rule moved by 6.6-11.8 degrees.
    V, F = dgmesh.read_mesh(CGAL / f"{name}.off")
    r = dgmesh.denoise(V, F)
    assert normal_error_deg(r.vertices, V, F).mean() < 0.5, (r.noise.sigma, r.noise.detail, r.options.smoothing_steps)


def uniform_taubin(P, F, steps):
    """Taubin lambda|mu smoothing (0.6, -0.62) with the uniform umbrella: the operator before session 24."""
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    deg = np.bincount(E.ravel(), minlength=len(P)).astype(float)[:, None]
    for _ in range(steps):
        for f in (0.6, -0.62):
            S = np.zeros_like(P)
            np.add.at(S, E[:, 0], P[E[:, 1]])
            np.add.at(S, E[:, 1], P[E[:, 0]])
            P = P + f * (S / deg - P)
    return P


DETAILED_SCANS = [c for c in (("cow", 0.05, 0.92), ("homer", 0.05, 0.9), ("ChineseDragon-10kv", 0.1, 0.93),
                              ("bull", 0.2, 0.95)) if (CGAL / f"{c[0]}.off").exists()]


@pytest.mark.parametrize("name,level,bound", DETAILED_SCANS)
def test_default_smoothing_beats_the_uniform_umbrella_on_detailed_scans(name, level, bound):
    # The automatic smoothing's operator is half cotangent: the uniform umbrella drifts vertices
    # along an irregular triangulation, which tilts its faces. Measured with seeds 1-3 (default /
    # uniform with the same step count): cow 0.05 e 0.888-0.895, homer 0.05 e 0.830-0.832,
    # ChineseDragon-10kv 0.1 e 0.869-0.891, bull 0.2 e 0.922-0.926; and the default lowers the error
    # (cow 8.41 -> 7.28, homer 7.46 -> 3.70, ChineseDragon-10kv 15.68 -> 8.98, bull 31.52 -> 18.72 degrees).
    V, F = dgmesh.read_mesh(CGAL / f"{name}.off")
    Vn = noisy(V, F, level, seed=1)
    r = dgmesh.denoise(Vn, F)
    assert r.options.smoothing_steps > 0 and r.iterations == 0
    err = normal_error_deg(r.vertices, V, F).mean()
    uniform = normal_error_deg(uniform_taubin(Vn, F, r.options.smoothing_steps), V, F).mean()
    assert err < bound * uniform, (err, uniform)
    assert err < 0.9 * normal_error_deg(Vn, V, F).mean()


def test_automatic_reports_its_estimate_and_options(sphere):
    V, F, Vn = sphere
    r = dgmesh.denoise(Vn, F)
    assert r.options.automatic
    est = dgmesh.estimate_noise(Vn, F)
    assert r.noise == est
    rule = dgmesh.denoising._native.auto_options(est, dgmesh.DenoiseOptions())
    steps = dgmesh.denoising._native.auto_smoothing_steps(est)
    if r.options.smoothing_steps:  # the automatic choice smoothed instead of filtering
        assert r.options.smoothing_steps == steps and r.iterations == 0
        rule.smoothing_steps, rule.iterations = steps, 0
    assert r.options == rule
    assert r.options.quadratic_fit and r.iterations == r.options.iterations
    # An eta1 or iterations given means the manual setting; automatic=True overrides them.
    manual = dgmesh.denoise(Vn, F, eta1=0.4)
    assert not manual.options.automatic and manual.options.eta1 == 0.4 and manual.noise.sigma == 0
    forced = dgmesh.denoise(Vn, F, eta1=0.4, automatic=True)
    assert np.array_equal(forced.vertices, r.vertices)


def test_automatic_needs_enough_points():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.1]], float)
    F = np.array([[0, 1, 2], [1, 3, 2]])
    with pytest.raises(dgmesh.MeshError, match="distinct points"):
        dgmesh.denoise(V, F)
    assert dgmesh.denoise(V, F, automatic=False).vertices.shape == V.shape
