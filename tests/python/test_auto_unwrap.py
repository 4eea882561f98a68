"""auto_unwrap: one-click unwrap of closed meshes into packed disk charts (dgmesh/charts.h)."""

import numpy as np
import pytest

import dgmesh
from dgmesh import shapes


def capped_tube(n=24, rows=6, r=1.0, h=3.0):
    """A closed cylinder: a tube of n x rows quads (split in triangles) with a fan on each end."""
    t = 2 * np.pi * np.arange(n) / n
    ring = np.c_[r * np.cos(t), r * np.sin(t)]
    V = [np.c_[ring, np.full(n, h * k / rows)] for k in range(rows + 1)]
    V = np.vstack(V + [[[0, 0, 0]], [[0, 0, h]]])
    bottom, top = len(V) - 2, len(V) - 1
    F = []
    for k in range(rows):
        for i in range(n):
            a, b = k * n + i, k * n + (i + 1) % n
            F += [[a, b, b + n], [a, b + n, a + n]]
    for i in range(n):
        F.append([bottom, (i + 1) % n, i])
        F.append([top, rows * n + i, rows * n + (i + 1) % n])
    return V, np.array(F, np.int32)


def euler_and_loops(F):
    """Euler characteristic of the triangles F and the number of their boundary loops (computed here,
    independently of the library)."""
    he = {(int(a), int(b)) for f in F for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    edges = {tuple(sorted(e)) for e in he}
    verts = set(np.unique(F).tolist())
    boundary = [e for e in he if (e[1], e[0]) not in he]
    nxt = {}
    for a, b in boundary:
        if a in nxt:
            return None, None  # pinched boundary vertex: not a disk
        nxt[a] = b
    loops, seen = 0, set()
    for a, _ in boundary:
        if a in seen:
            continue
        loops += 1
        v = a
        while v not in seen:
            seen.add(v)
            v = nxt[v]
    return len(verts) - len(edges) + len(F), loops


def assert_disks(F, chart):
    for c in range(chart.max() + 1):
        chi, loops = euler_and_loops(F[chart == c])
        assert (chi, loops) == (1, 1), f"chart {c}: Euler characteristic {chi}, {loops} boundary loops"


def signed_areas(T):
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def assert_injective(r, m):
    """No flipped triangle, and every triangle's centroid lies in that triangle only: no overlap
    within a chart or between charts."""
    T = np.asarray(r.uv).reshape(m, 3, 2)
    a = signed_areas(T)
    assert (a > 0).all(), f"{int((a <= 0).sum())} flipped or zero-area UV triangles"
    c = T.mean(axis=1)
    inside = np.zeros(m, int)
    for k in range(0, m, 256):  # centroids k..k+256 against every triangle
        p = c[k:k + 256, None, :]
        s = [(T[None, :, (j + 1) % 3, 0] - T[None, :, j, 0]) * (p[..., 1] - T[None, :, j, 1])
             - (T[None, :, (j + 1) % 3, 1] - T[None, :, j, 1]) * (p[..., 0] - T[None, :, j, 0]) for j in range(3)]
        inside[k:k + 256] = ((s[0] > -1e-12) & (s[1] > -1e-12) & (s[2] > -1e-12)).sum(axis=1)
    assert (inside == 1).all(), f"{int((inside > 1).sum())} triangle centroids covered by other triangles"
    assert T.min() >= -1e-12 and T.max() <= 1 + 1e-12


def test_cube_unwraps_into_its_six_faces_without_stretch():
    V, F = shapes.rounded_cube(4, 0.0)
    r = dgmesh.auto_unwrap(V, F, charts=6)
    assert r.n_charts == 6 and r.topology_splits == 0 and r.stretch_splits == 0
    assert r.metrics.stretch_l2 == pytest.approx(1.0, abs=1e-6)
    assert np.allclose(r.chart_stretch, 1.0, atol=1e-6)
    assert_disks(F, np.asarray(r.chart))
    assert_injective(r, len(F))
    # The seams are the cube's 12 edges: both ends of every seam edge on two faces of the cube.
    S = np.asarray(r.seams)
    on_edge = (np.abs(np.abs(V[S]) - 1) < 1e-9).sum(axis=2) >= 2
    assert on_edge.all()
    assert r.seam_length == pytest.approx(12 * 2.0)
    # Each chart is a flat face: its triangles share one normal.
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N /= np.linalg.norm(N, axis=1)[:, None]
    for c in range(6):
        assert np.allclose(N[np.asarray(r.chart) == c], N[np.asarray(r.chart) == c][0])


def test_cube_default_charts_stay_isometric():
    V, F = shapes.rounded_cube(4, 0.0)
    r = dgmesh.auto_unwrap(V, F)
    assert r.n_charts >= 6
    assert r.metrics.stretch_l2 == pytest.approx(1.0, abs=1e-6)
    assert r.metrics.flipped == 0 and r.metrics.zero_area == 0
    assert_disks(F, np.asarray(r.chart))
    assert_injective(r, len(F))


def test_closed_cylinder_charts_are_disks_within_the_stretch_bound():
    V, F = capped_tube()
    r = dgmesh.auto_unwrap(V, F, max_stretch=1.05)
    chart = np.asarray(r.chart)
    assert_disks(F, chart)
    assert_injective(r, len(F))
    assert (np.asarray(r.chart_stretch) <= 1.05).all()
    assert r.metrics.stretch_l2 <= 1.05
    # The caps are flat discs: a cut runs around each cap's rim, so no chart holds faces of both caps.
    z = V[F].mean(axis=1)[:, 2]
    assert not set(chart[z < 1e-9]) & set(chart[z > 3 - 1e-9])
    # The seams agree with the charts: an edge is a seam exactly when its two faces differ in chart.
    E = np.sort(np.c_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]].reshape(-1, 2), axis=1)
    face = np.repeat(np.arange(len(F)), 3)
    order = np.lexsort((E[:, 1], E[:, 0]))
    E, face = E[order], face[order]
    pairs = E[0::2]
    assert (pairs == E[1::2]).all()
    cut = chart[face[0::2]] != chart[face[1::2]]
    assert {tuple(e) for e in pairs[cut]} == {tuple(e) for e in np.asarray(r.seams)}


def test_torus_needs_two_cuts_and_every_chart_is_a_disk():
    V, F = shapes.torus(2.0, 0.7, 32, 16)
    r = dgmesh.auto_unwrap(V, F, charts=1, max_stretch=None)
    chart = np.asarray(r.chart)
    assert r.initial_charts == 1 and r.topology_splits >= 1
    assert_disks(F, chart)
    assert_injective(r, len(F))
    # A cut graph that leaves disks on a torus (Euler characteristic 0) has cycle rank >= 2.
    S = np.asarray(r.seams)
    nv = len(np.unique(S))
    parent = {v: v for v in np.unique(S).tolist()}

    def root(x):
        while parent[x] != x:
            x = parent[x]
        return x
    for a, b in S.tolist():
        parent[root(a)] = root(b)
    components = len({root(v) for v in parent})
    assert len(S) - nv + components >= 2


def test_stretch_bound_splits_a_sphere():
    V, F = shapes.icosphere(3)
    loose = dgmesh.auto_unwrap(V, F, charts=2, max_stretch=None)
    tight = dgmesh.auto_unwrap(V, F, charts=2, max_stretch=1.01)
    assert loose.n_charts == 2 and loose.stretch_splits == 0
    assert loose.chart_stretch.max() > 1.01  # a hemisphere stretches more than that (1.02)
    assert tight.stretch_splits > 0 and tight.n_charts > 2
    assert (np.asarray(tight.chart_stretch) <= 1.01).all()
    assert tight.metrics.stretch_l2 < loose.metrics.stretch_l2
    assert_disks(F, np.asarray(tight.chart))
    assert_injective(tight, len(F))


def test_chart_is_disk():
    V, F = shapes.grid(4, 4)
    F = np.asarray(F, np.int32)
    assert dgmesh._native.chart_is_disk(F, list(range(len(F))))
    Vt, Ft = shapes.torus(2.0, 0.7, 8, 6)
    assert not dgmesh._native.chart_is_disk(np.asarray(Ft, np.int32), list(range(len(Ft))))
    # An annulus: the grid without its middle triangles (two boundary loops).
    c = V[F].mean(axis=1)
    ring = np.flatnonzero(np.abs(c[:, :2] - c[:, :2].mean(0)).max(axis=1) > 0.2)
    assert not dgmesh._native.chart_is_disk(F, ring.tolist())


@pytest.mark.parametrize("kwargs, match", [
    (dict(max_stretch=1.0), "max_stretch"),
    (dict(max_stretch=float("nan")), "max_stretch"),
    (dict(charts=0), "charts"),
    (dict(charts=10 ** 6), "charts"),
    (dict(max_charts=0), "max_charts"),
    (dict(margin=-0.1), "margin"),
    (dict(margin=0.3), "margin"),
])
def test_bad_options(kwargs, match):
    V, F = shapes.icosphere(1)
    with pytest.raises(dgmesh.MeshError, match=match):
        dgmesh.auto_unwrap(V, F, **kwargs)


def test_bad_meshes():
    V, F = shapes.icosphere(1)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.auto_unwrap(V, F[:, :2])
    bad = V.copy()
    bad[0, 0] = np.nan
    with pytest.raises(dgmesh.MeshError):
        dgmesh.auto_unwrap(bad, F)
    flipped = F.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(dgmesh.MeshError):
        dgmesh.auto_unwrap(V, flipped)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.auto_unwrap(V, np.zeros((0, 3), np.int32))


def test_progress_and_cancel():
    V, F = shapes.icosphere(3)
    seen = []
    dgmesh.auto_unwrap(V, F, progress=lambda f: seen.append(f) or True)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    with pytest.raises(dgmesh.Cancelled):
        dgmesh.auto_unwrap(V, F, progress=lambda f: f < 0.5)


def test_groups_are_never_cut_apart():
    # Quads of a tube-like torus: pairs of triangles (2i, 2i+1) form one quad in shapes.torus.
    V, F = shapes.torus(2.0, 0.7, 24, 12)
    groups = np.arange(len(F)) // 2
    r = dgmesh.auto_unwrap(V, F, groups=groups, max_stretch=1.05)
    chart = np.asarray(r.chart)
    assert (chart[0::2] == chart[1::2]).all()
    assert_disks(F, chart)
    assert_injective(r, len(F))
    # Without groups some quad is cut in two on this mesh (else the check above proves nothing).
    free = np.asarray(dgmesh.auto_unwrap(V, F, max_stretch=1.05).chart)
    assert (free[0::2] != free[1::2]).any()
    with pytest.raises(dgmesh.MeshError, match="groups"):
        dgmesh.auto_unwrap(V, F, groups=groups[:-1])
