"""Python API of crest lines, decimation and segmentation (thesis chapter 4)."""

import numpy as np
import pytest

import dgmesh
from dgmesh import _native
from dgmesh import shapes
from dgmesh.crest import RIDGE, VALLEY, snap_to_vertices


@pytest.fixture(scope="module")
def cube():
    return shapes.rounded_cube()


def test_rounded_cube_ridges(cube):
    V, F = cube
    cl = dgmesh.crest_lines(V, F, threshold=8.0)
    assert len(cl) > 0
    assert np.all(cl.line_kind == RIDGE)
    # Points on the middles of the rounded edges or in the corners, never on the flat sides.
    near = (np.abs(cl.points) > 0.7).sum(axis=1)
    assert np.all(near >= 2)
    # Total length: 12 edges of straight length 1.4 at least.
    assert cl.total_length > 12 * 1.4
    assert cl.line_strength.min() >= 8.0
    assert sum(len(p) for p in cl.polylines) == len(cl.line_points)


def test_filter_reuses_fit_and_restores_lines(cube):
    V, F = cube
    strong = dgmesh.crest_lines(V, F, threshold=8.0)
    everything = strong.filter(0.0)
    assert len(everything) >= len(strong)
    assert strong.filter(8.0).n_lines == strong.n_lines
    assert np.array_equal(strong.filter(8.0).points, strong.points)
    assert everything.filter(8.0).n_lines == strong.n_lines
    assert strong.filter(0.0, ridges=False, valleys=False).n_lines == 0
    # Segments index valid points of their own line set.
    assert everything.segments.max() < len(everything.points)


def test_sphere_and_plane_have_no_lines_after_thresholding():
    V, F = _native.icosphere(4, 3.0)
    assert len(dgmesh.crest_lines(V, F, threshold=8.0)) == 0
    V, F = _native.grid(20, 20)
    assert len(dgmesh.crest_lines(V, F, threshold=1e-6)) == 0


def test_curvature_derivatives_sphere():
    V, F = _native.icosphere(4, 2.0)
    d = dgmesh.curvature_derivatives(V, F, smooth=False)
    assert np.allclose(d.k_max, 0.5, atol=0.01)
    assert np.allclose(d.k_min, 0.5, atol=0.01)
    assert np.abs(d.e_max).max() < 0.01
    assert d.t_max.shape == (len(V), 3)


def test_orientation_duality(cube):
    V, F = cube
    a = dgmesh.crest_lines(V, F, threshold=8.0)
    b = dgmesh.crest_lines(V, F[:, ::-1], threshold=8.0)
    assert np.all(b.line_kind == VALLEY)
    assert abs(a.total_length - b.total_length) < 0.05 * a.total_length


def test_snap_to_vertices_gives_mesh_edges(cube):
    V, F = cube
    cl = dgmesh.crest_lines(V, F, threshold=8.0)
    pairs, line = snap_to_vertices(cl, V, F)
    assert len(pairs) == len(line) > 0
    edges = {tuple(sorted(e)) for t in F for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    inside = [tuple(sorted(p)) in edges for p in pairs]
    # All but gap jumps are edges of the triangle they cross.
    assert np.mean(inside) > 0.95


def test_decimate_manifold_and_feature_weight(cube):
    V, F = cube
    for greedy in (False, True):
        V2, F2 = dgmesh.decimate(V, F, target_faces=len(F) // 10, feature_weight=0.0, greedy=greedy)
        assert len(F2) <= len(F) // 10
        dgmesh.validate(V2, F2, allow_loose_vertices=False)
    V3, F3, vmap = dgmesh.decimate(V, F, target_faces=len(F) // 10, feature_weight=6.0, threshold=8.0,
                                   return_map=True)
    dgmesh.validate(V3, F3, allow_loose_vertices=False)
    assert vmap.shape == (len(V),) and vmap.min() >= 0 and vmap.max() < len(V3)


def test_decimate_face_map_and_source_vertex(cube):
    V, F = cube
    V2, F2, vmap, fmap, src = dgmesh.decimate(V, F, target_faces=len(F) // 5, feature_weight=0.0, return_map=True,
                                              return_face_map=True)
    assert fmap.shape == (len(F2),) and src.shape == (len(V2),)
    # Output face j is input face fmap[j] with its corners sent through the vertex map.
    assert np.array_equal(vmap[F[fmap]], F2)
    # Each output vertex is a surviving input vertex, which maps to itself.
    assert np.array_equal(vmap[src], np.arange(len(V2)))
    assert len(np.unique(fmap)) == len(fmap)


def test_decimate_locked_vertices_stay(cube):
    V, F = cube
    locked = V[:, 2] > 0.5  # the top of the cube
    V2, F2, vmap, fmap, src = dgmesh.decimate(V, F, target_faces=len(F) // 5, feature_weight=0.0, locked=locked,
                                              return_map=True, return_face_map=True)
    # Every locked vertex survives, unmoved; the rest of the mesh is decimated.
    assert np.array_equal(vmap[np.flatnonzero(locked)], np.searchsorted(src, np.flatnonzero(locked)))
    assert np.isin(np.flatnonzero(locked), src).all()
    assert np.array_equal(V2[vmap[locked]], V[locked])
    assert len(F2) < len(F) and (V2[:, 2] <= 0.5).sum() < (V[:, 2] <= 0.5).sum() / 3
    with pytest.raises(dgmesh.MeshError, match="one bool per item"):
        dgmesh.decimate(V, F, target_faces=10, locked=locked[:-1])


def test_decimate_keeps_boundary():
    V, F = _native.grid(20, 20)
    V2, F2 = dgmesh.decimate(V, F, target_faces=100, feature_weight=0.0)
    loops = dgmesh.topology(V2, F2).boundary_loops
    assert len(loops) == 1 and len(loops[0]) == 80


def test_segment_connected_cover(cube):
    V, F = cube
    for eta in (0.0, 2.0):
        labels, info = dgmesh.segment(V, F, segments=6, feature_weight=eta, threshold=8.0, return_info=True)
        assert labels.shape == (len(F),)
        assert set(labels.tolist()) == set(range(6))
        assert info.n_segments == 6


def test_bad_input():
    V, F = _native.icosphere(2, 1.0)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.crest_lines(V, F, rings=0)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.crest_lines(V[:, :2], F)
    Fbad = F.copy()
    Fbad[0, 0] = len(V) + 5
    with pytest.raises(dgmesh.MeshError):
        dgmesh.crest_lines(V, Fbad)
    Vnan = V.copy()
    Vnan[3, 1] = np.nan
    with pytest.raises(dgmesh.MeshError):
        dgmesh.curvature_derivatives(Vnan, F)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.decimate(V, F, target_faces=-1)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.decimate(V, F, target_faces=10, feature_weight=-1)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.segment(V, F, segments=0)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.segment(V, F, segments=10 * len(F))
    other = dgmesh.crest_lines(*_native.icosphere(4, 1.0), threshold=0.0)
    if len(other.point_edge) and other.point_edge.max() >= len(V):
        with pytest.raises(dgmesh.MeshError):
            dgmesh.decimate(V, F, target_faces=10, feature_weight=2.0, crest_lines=other)


@pytest.mark.parametrize("which", ["crest_lines", "decimate", "segment"])
def test_progress_reports_and_cancels(cube, which):
    V, F = cube
    calls = {
        "crest_lines": lambda cb: dgmesh.crest_lines(V, F, progress=cb),
        "decimate": lambda cb: dgmesh.decimate(V, F, target_faces=len(F) // 10, progress=cb),
        "segment": lambda cb: dgmesh.segment(V, F, segments=6, progress=cb),
    }[which]
    seen = []
    calls(lambda f: seen.append(f) or True)
    assert seen and all(0.0 <= f <= 1.0 for f in seen) and seen[-1] == 1.0
    with pytest.raises(dgmesh.Cancelled):
        calls(lambda f: False)


def test_feature_guided_calls_detect_or_take_lines_alike(cube):
    """Detecting the lines inside decimate/segment (one validation of the mesh) gives the same
    result as handing over dgmesh.crest_lines' result."""
    V, F = cube
    lines = dgmesh.crest_lines(V, F, rings=1, threshold=8.0)
    a = dgmesh.decimate(V, F, target_faces=len(F) // 8, feature_weight=6.0, threshold=8.0)
    b = dgmesh.decimate(V, F, target_faces=len(F) // 8, feature_weight=6.0, crest_lines=lines)
    c = dgmesh.decimate(V, F, target_faces=len(F) // 8, feature_weight=0.0)
    assert np.array_equal(a[1], b[1]) and np.allclose(a[0], b[0])
    assert not (len(a[1]) == len(c[1]) and np.array_equal(a[1], c[1]))  # the weights change the result
    la = dgmesh.segment(V, F, segments=6, feature_weight=2.0, threshold=8.0)
    lb = dgmesh.segment(V, F, segments=6, feature_weight=2.0, crest_lines=lines)
    assert np.array_equal(la, lb)


def test_feature_progress_covers_fit_and_decimation(cube):
    V, F = cube
    seen = []
    dgmesh.decimate(V, F, target_faces=len(F) // 10, feature_weight=6.0, threshold=8.0,
                    progress=lambda f: seen.append(f) or True)
    assert seen == sorted(seen) and seen[0] == 0.0 and seen[-1] == 1.0
    assert any(0.0 < f <= 0.3 for f in seen)  # the fit's share
    with pytest.raises(dgmesh.MeshError, match="another mesh"):
        other = dgmesh.crest_lines(*_native.icosphere(4, 1.0), threshold=0.0)
        dgmesh.segment(*_native.icosphere(1, 1.0), segments=3, feature_weight=2.0, crest_lines=other)


def test_crest_lines_of_a_smaller_or_larger_mesh_are_refused():
    V, F = shapes.icosphere(2)  # 162 vertices
    for n in (4, 12):  # rounded cubes of 98 and more vertices than the sphere
        other = dgmesh.crest_lines(*shapes.rounded_cube(n), threshold=0.0)
        with pytest.raises(dgmesh.MeshError, match="another mesh"):
            dgmesh.decimate(V, F, target_faces=50, feature_weight=1.0, crest_lines=other)
        with pytest.raises(dgmesh.MeshError, match="another mesh"):
            dgmesh.segment(V, F, segments=4, feature_weight=1.0, crest_lines=other)
        with pytest.raises(dgmesh.MeshError, match="another mesh"):
            snap_to_vertices(other, V, F)
