"""auto_unwrap: one-click unwrap of closed meshes into packed disk charts (dgmesh/charts.h)."""

import numpy as np
import pytest

import dgmesh
from dgmesh import shapes


def open_tube(n=24, rows=6, r=1.0, h=3.0):
    """A tube without caps (an annulus): n x rows quads split in triangles, rings at z = 0 .. h."""
    t = 2 * np.pi * np.arange(n) / n
    ring = np.c_[r * np.cos(t), r * np.sin(t)]
    V = np.vstack([np.c_[ring, np.full(n, h * k / rows)] for k in range(rows + 1)])
    F = []
    for k in range(rows):
        for i in range(n):
            a, b = k * n + i, k * n + (i + 1) % n
            F += [[a, b, b + n], [a, b + n, a + n]]
    return V, np.array(F, np.int32)


def capped_tube(n=24, rows=6, r=1.0, h=3.0):
    """A closed cylinder: a tube of n x rows quads (split in triangles) with a fan on each end."""
    V, F = open_tube(n, rows, r, h)
    V = np.vstack([V, [[0, 0, 0]], [[0, 0, h]]])
    bottom, top = len(V) - 2, len(V) - 1
    F = F.tolist()
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


def cut_open(F, r):
    """The triangles F with one vertex per (vertex, UV) pair of the result's corner UVs: the mesh
    cut along its seams, as the charts are laid out."""
    uv = np.round(np.asarray(r.uv), 9)
    keys = np.c_[F.reshape(-1), uv]
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    return ids.reshape(-1, 3)


def assert_disks(F, r):
    """Every chart, cut open along the seams, is a disk."""
    chart, Fc = np.asarray(r.chart), cut_open(F, r)
    for c in range(chart.max() + 1):
        chi, loops = euler_and_loops(Fc[chart == c])
        assert (chi, loops) == (1, 1), f"chart {c}: Euler characteristic {chi}, {loops} boundary loops"


def uv_split_edges(F, r):
    """The edges (v0 < v1) whose two sides have different corner UVs: the seams as laid out."""
    uv = np.asarray(r.uv).reshape(-1, 3, 2)
    side = {}
    for f in range(len(F)):
        for k in range(3):
            a, b = int(F[f, k]), int(F[f, (k + 1) % 3])
            side.setdefault((min(a, b), max(a, b)), []).append({a: tuple(uv[f, k]), b: tuple(uv[f, (k + 1) % 3])})
    return {e for e, s in side.items() if len(s) == 2 and any(
        np.abs(np.subtract(s[0][v], s[1][v])).max() > 1e-9 for v in e)}


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
    r = dgmesh.auto_unwrap(V, F, charts=6, merge=False)
    assert r.n_charts == 6 and r.topology_splits == 0 and r.stretch_splits == 0
    assert r.metrics.stretch_l2 == pytest.approx(1.0, abs=1e-6)
    assert np.allclose(r.chart_stretch, 1.0, atol=1e-6)
    assert_disks(F, r)
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


def test_cube_default_charts_stay_isometric_and_merge_within_the_target():
    V, F = shapes.rounded_cube(4, 0.0)
    flat = dgmesh.auto_unwrap(V, F, merge=False)
    assert flat.n_charts >= 6 and flat.merges == 0
    assert flat.metrics.stretch_l2 == pytest.approx(1.0, abs=1e-6)
    # Merged: faces around a cube corner (270 degrees) cannot lie flat without stretch, so fewer
    # charts cost stretch, up to the whole map's target.
    r = dgmesh.auto_unwrap(V, F, target_stretch=1.05)
    assert r.merges > 0 and r.n_charts < 6
    assert 1.0 + 1e-3 < r.metrics.stretch_l2 <= 1.05
    for x in (flat, r):
        assert x.metrics.flipped == 0 and x.metrics.zero_area == 0
        assert_disks(F, x)
        assert_injective(x, len(F))


def test_closed_cylinder_charts_are_disks_within_the_stretch_bound():
    V, F = capped_tube()
    r = dgmesh.auto_unwrap(V, F, max_stretch=1.05)
    chart = np.asarray(r.chart)
    assert_disks(F, r)
    assert_injective(r, len(F))
    assert (np.asarray(r.chart_stretch) <= 1.05).all()
    assert r.metrics.stretch_l2 <= 1.05
    # The caps are flat discs: a cut runs around each cap's rim, so no chart holds faces of both caps.
    z = V[F].mean(axis=1)[:, 2]
    assert not set(chart[z < 1e-9]) & set(chart[z > 3 - 1e-9])
    # The seams agree with the layout: an edge is a seam exactly when its UVs differ on its two
    # sides, and every edge between two charts is one.
    seams = {tuple(e) for e in np.asarray(r.seams).tolist()}
    assert uv_split_edges(F, r) == seams
    E = np.sort(np.c_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]].reshape(-1, 2), axis=1)
    face = np.repeat(np.arange(len(F)), 3)
    order = np.lexsort((E[:, 1], E[:, 0]))
    E, face = E[order], face[order]
    pairs = E[0::2]
    assert (pairs == E[1::2]).all()
    between = chart[face[0::2]] != chart[face[1::2]]
    assert {tuple(e) for e in pairs[between].tolist()} <= seams


def test_open_tube_is_one_chart_cut_once_from_rim_to_rim():
    # An annulus of flat rectangles (split in triangles) is developable: cut along one ruling it
    # unrolls into a rectangle without stretch. Known answer: one chart, whose only seam is a path
    # of `rows` edges from the bottom rim (z = 0) to the top rim (z = h), of length h.
    n, rows, h = 24, 6, 3.0
    V, F = open_tube(n, rows, 1.0, h)
    r = dgmesh.auto_unwrap(V, F)
    assert r.n_charts == 1
    assert r.metrics.stretch_l2 < 1.01 and r.metrics.flipped == 0 and r.metrics.zero_area == 0
    assert_disks(F, r)
    assert_injective(r, len(F))
    S = np.asarray(r.seams)
    assert uv_split_edges(F, r) == {tuple(e) for e in S.tolist()}
    assert len(S) == rows and r.seam_length == pytest.approx(h)
    # A single path: its vertices have degree 2 but for two ends, one on each rim.
    verts, deg = np.unique(S, return_counts=True)
    assert len(verts) == rows + 1 and sorted(deg.tolist()) == [1, 1] + [2] * (rows - 1)
    ends = verts[deg == 1]
    assert sorted(V[ends, 2].tolist()) == pytest.approx([0.0, h])
    # Without merging the initial segments stay separate charts: the merge step made it one.
    assert dgmesh.auto_unwrap(V, F, merge=False).n_charts > 1


@pytest.mark.parametrize("kwargs", [dict(charts=1, max_stretch=None, target_stretch=None, merge=False), {}])
def test_torus_needs_two_cuts_and_every_chart_is_a_disk(kwargs):
    V, F = shapes.torus(2.0, 0.7, 32, 16)
    r = dgmesh.auto_unwrap(V, F, **kwargs)
    if kwargs:
        assert r.initial_charts == 1 and r.topology_splits >= 1
    assert_disks(F, r)
    assert_injective(r, len(F))
    assert r.metrics.stretch_l2 <= (1.05 if not kwargs else np.inf)
    # A cut graph that leaves disks on a torus (Euler characteristic 0) has cycle rank >= 2.
    S = np.asarray(r.seams)
    assert uv_split_edges(F, r) == {tuple(e) for e in S.tolist()}
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
    loose = dgmesh.auto_unwrap(V, F, charts=2, max_stretch=None, target_stretch=None)
    tight = dgmesh.auto_unwrap(V, F, charts=2, max_stretch=1.01, merge=False)
    assert loose.n_charts == 2 and loose.stretch_splits == 0
    assert loose.chart_stretch.max() > 1.01  # a hemisphere stretches more than that (1.02)
    assert tight.stretch_splits > 0 and tight.n_charts > 2
    assert (np.asarray(tight.chart_stretch) <= 1.01).all()
    assert tight.metrics.stretch_l2 < loose.metrics.stretch_l2
    assert_disks(F, tight)
    assert_injective(tight, len(F))
    # The whole map's bound: split until the packed map's L2 is within it (no bound per chart).
    whole = dgmesh.auto_unwrap(V, F, charts=2, max_stretch=None, target_stretch=1.005)
    assert whole.stretch_splits > 0 and whole.metrics.stretch_l2 <= 1.005
    # The packed map's L2 is the area-weighted root mean square of the charts' own (charts.h).
    A = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1) / 2
    Ac = np.bincount(np.asarray(whole.chart), A)
    rms = np.sqrt((Ac * np.asarray(whole.chart_stretch) ** 2).sum() / A.sum())
    assert whole.metrics.stretch_l2 == pytest.approx(rms, rel=1e-6)
    assert_disks(F, whole)


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
    (dict(target_stretch=0.9), "target_stretch"),
    (dict(merge="no"), "merge"),
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
    # The quads' diagonals: the edge the two triangles of a quad share.
    diagonals = {tuple(sorted(set(F[2 * i].tolist()) & set(F[2 * i + 1].tolist()))) for i in range(len(F) // 2)}

    def cut_quads(r):
        chart = np.asarray(r.chart)
        return int((chart[0::2] != chart[1::2]).sum()) + len(diagonals & {tuple(e) for e in np.asarray(r.seams).tolist()})
    for merge in (True, False):
        r = dgmesh.auto_unwrap(V, F, groups=groups, charts=12, max_stretch=1.05, merge=merge)
        assert cut_quads(r) == 0
        assert_disks(F, r)
        assert_injective(r, len(F))
        # Without groups some quad is cut in two on this mesh (else the check above proves nothing).
        assert cut_quads(dgmesh.auto_unwrap(V, F, charts=12, max_stretch=1.05, merge=merge)) > 0
    with pytest.raises(dgmesh.MeshError, match="groups"):
        dgmesh.auto_unwrap(V, F, groups=groups[:-1])
