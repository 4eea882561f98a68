"""dgmesh.estimate_noise: the noise level from leverage-standardised residuals of local cubic fits."""

from pathlib import Path

import numpy as np
import pytest

import dgmesh
from dgmesh import shapes

CGAL = Path(__file__).resolve().parents[2] / ".cache" / "cgal-data" / "data" / "meshes"
LEVELS = (0.05, 0.1, 0.2, 0.3)


def edge_length(V, F):
    return float(np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2).mean())


def graph():
    """An analytic graph z = 0.3 sin(2x) cos(3y) over a 40 x 40 grid of the unit square."""
    V, F = shapes.grid(40, 40)
    V = V.copy()
    V[:, 2] = 0.3 * np.sin(2 * V[:, 0]) * np.cos(3 * V[:, 1])
    return V, F


SHAPES = {
    "icosphere": lambda: shapes.icosphere(4, 1.0),
    "torus": lambda: shapes.torus(1.0, 0.35, 96, 40),
    "graph": graph,
}
if (CGAL / "bunny00.off").exists():
    SHAPES["bunny00"] = lambda: dgmesh.read_mesh(CGAL / "bunny00.off")


def add_noise(V, F, level, kind, seed):
    """Gaussian noise of deviation level * e: along the clean normals, or in each coordinate."""
    rng = np.random.default_rng(seed)
    s = level * edge_length(V, F)
    if kind == "normal":
        N = dgmesh.curvature(V, F).normals
        return V + N * rng.normal(0.0, s, (len(V), 1))
    return V + rng.normal(0.0, s, V.shape)


@pytest.fixture(scope="module", params=sorted(SHAPES))
def shape(request):
    V, F = SHAPES[request.param]()
    return request.param, np.asarray(V, dtype=np.float64), np.asarray(F)


@pytest.mark.parametrize("kind", ["normal", "isotropic"])
def test_estimate_within_20_percent(shape, kind):
    name, V, F = shape
    e = edge_length(V, F)
    for i, level in enumerate(LEVELS):
        Vn = add_noise(V, F, level, kind, seed=10 + i)
        est = dgmesh.estimate_noise(Vn, F)
        assert isinstance(est, dgmesh.NoiseEstimate)
        ratio = est.sigma_abs / (level * e)
        assert 0.8 < ratio < 1.2, f"{name} {kind} {level}: estimate {est.sigma_abs / e:.4f} e"
        # The reported unit is the noisy mesh's mean edge length.
        assert est.sigma == pytest.approx(est.sigma_abs / est.edge_length, rel=1e-12)
        assert est.edge_length == pytest.approx(edge_length(Vn, F), rel=1e-9)


def test_noise_free_reads_near_zero(shape):
    name, V, F = shape
    est = dgmesh.estimate_noise(V, F)
    if name == "bunny00":
        # A real scan carries its scanner's noise: measured 0.0114 e, far below the added levels.
        assert est.sigma < 0.02
        return
    assert est.sigma < 0.005, f"{name}: {est.sigma:.4f} e on the clean mesh"
    assert est.samples == len(V)


def test_curvature_reads_the_sampling():
    # A sphere of radius 1 with edge length e: e * |kappa| = e.
    V, F = shapes.icosphere(4, 1.0)
    est = dgmesh.estimate_noise(V, F)
    assert est.curvature == pytest.approx(edge_length(V, F), rel=0.1)
    Vg, Fg = shapes.grid(30, 30)
    assert dgmesh.estimate_noise(Vg, Fg).curvature < 1e-9


def test_detail_reads_shape_not_noise():
    # Noise reads the same at both fit widths, so it adds (almost) no detail; the noise-free coarse
    # elephant (2775 vertices) reads its shape at the sampling scale as detail, above twice its sigma.
    V, F = shapes.icosphere(4, 1.0)
    assert dgmesh.estimate_noise(V, F).detail < 0.01
    for level in (0.1, 0.3):
        est = dgmesh.estimate_noise(add_noise(V, F, level, "isotropic", seed=5), F)
        assert est.detail < 0.35 * est.sigma, f"{level}: detail {est.detail:.3f}, sigma {est.sigma:.3f}"
    if (CGAL / "elephant.off").exists():
        est = dgmesh.estimate_noise(*dgmesh.read_mesh(CGAL / "elephant.off"))
        assert est.detail > 2 * est.sigma  # measured 0.213 against 0.090 e


@pytest.mark.skipif(not (CGAL / "ChineseDragon-10kv.off").exists(), reason="CGAL data not unpacked")
@pytest.mark.xfail(strict=True, reason="issue 32, open: a scan sampled at its own detail's scale reads that detail as "
                   "noise (noise-free 0.078 e); no local-fit estimate measured in bench/notes/denoise.md session 25 "
                   "(two- and three-width extrapolations, quadric and cubic fits) separates it from 0.05 e of noise")
def test_detailed_scan_with_low_noise_reads_the_noise():
    # The defect behind the automatic denoise's 0 steps at 0.05 e on ChineseDragon-10kv: the estimate
    # reads about sqrt(shape^2 + noise^2) (measured 2.00 normal, 1.95 isotropic times the true sigma).
    # If an estimate learns to tell the two apart this passes, and the strict xfail fails: then drop
    # the mark.
    V, F = dgmesh.read_mesh(CGAL / "ChineseDragon-10kv.off")
    V, F = np.asarray(V, dtype=np.float64), np.asarray(F)
    for kind in ("normal", "isotropic"):
        est = dgmesh.estimate_noise(add_noise(V, F, 0.05, kind, seed=11), F)
        ratio = est.sigma_abs / (0.05 * edge_length(V, F))
        assert 0.8 < ratio < 1.2, f"{kind}: {ratio:.2f} times the true sigma"


def test_point_cloud_and_soup_give_the_mesh_estimate():
    V, F = shapes.icosphere(4, 1.0)
    Vn = add_noise(V, F, 0.2, "normal", seed=3)
    mesh = dgmesh.estimate_noise(Vn, F)
    cloud = dgmesh.estimate_noise(Vn, None)
    assert cloud.sigma_abs == pytest.approx(mesh.sigma_abs, rel=1e-12)  # the same points, the same fits
    assert cloud.edge_length > 0
    soup_V = Vn[F].reshape(-1, 3)
    soup_F = np.arange(len(soup_V)).reshape(-1, 3)
    soup = dgmesh.estimate_noise(soup_V, soup_F)
    assert soup.samples == mesh.samples
    assert soup.sigma_abs == pytest.approx(mesh.sigma_abs, rel=1e-12)


def test_sharp_features_do_not_read_as_noise():
    # A cube's edges and corners cannot be fitted by a cubic: they are outliers, not noise.
    V, F = shapes.rounded_cube(20, 0.0)
    est = dgmesh.estimate_noise(V, F)
    assert est.sigma < 0.02
    assert est.outliers > 0.05


def test_bad_input_raises_mesh_error():
    V, F = shapes.icosphere(2, 1.0)
    with pytest.raises(dgmesh.MeshError, match="neighbours"):
        dgmesh.estimate_noise(V, F, neighbours=11)
    with pytest.raises(dgmesh.MeshError, match="neighbours"):
        dgmesh.estimate_noise(V, F, neighbours=2.5)
    bad = V.copy()
    bad[3, 1] = np.nan
    with pytest.raises(dgmesh.MeshError, match="non-finite"):
        dgmesh.estimate_noise(bad, F)
    with pytest.raises(dgmesh.MeshError, match="distinct points"):
        dgmesh.estimate_noise(V[:10], None)
    with pytest.raises(dgmesh.MeshError, match="positive area"):
        dgmesh.estimate_noise(np.zeros((3, 3)), [[0, 1, 2]])
    with pytest.raises(dgmesh.MeshError):
        dgmesh.estimate_noise(V, [[0, 1, len(V)]])


def test_progress_and_cancel():
    V, F = shapes.icosphere(3, 1.0)
    seen = []
    dgmesh.estimate_noise(V, F, progress=lambda f: seen.append(f))
    assert seen[0] == 0.0 and seen[-1] == 1.0
    with pytest.raises(dgmesh.Cancelled):
        dgmesh.estimate_noise(V, F, progress=lambda f: False)
