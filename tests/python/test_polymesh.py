"""dgmesh.polymesh: the add-on's polygon-mesh work in plain numpy (n-gon triangle repair, edge
lookup and routing, region orientation, mirror planes, seam charts, attribute transfer, corners of
new triangles, result measures, vertex references, crest lines as edges)."""

import numpy as np
import pytest

import dgmesh
from dgmesh import polymesh, shapes
from dgmesh.polymesh import MeshArrays


def polygon_arrays(polygons):
    """(start, total, loop_vertex, edges, loop_edge) of polygons (vertex lists) as Blender stores
    them: loops polygon after polygon, edge l joining loop l's vertex to the next loop's."""
    total = np.array([len(p) for p in polygons])
    start = np.r_[0, np.cumsum(total)[:-1]]
    lv = np.concatenate([np.asarray(p) for p in polygons])
    nxt = np.concatenate([np.roll(np.asarray(p), -1) for p in polygons])
    pairs = np.sort(np.column_stack([lv, nxt]), axis=1)
    edges, loop_edge = np.unique(pairs, axis=0, return_inverse=True)
    return start, total, lv, edges, loop_edge.ravel()


def signed_areas(V, F):
    """z of the cross products: twice the signed area of triangles in the z = 0 plane."""
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    return e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]


# --- edge keys and lookup --------------------------------------------------------------------

def test_edge_keys_are_one_per_undirected_edge_and_sort_like_pairs():
    a, b = np.array([3, 1, 0, 2, 4]), np.array([1, 3, 4, 0, 0])
    keys = polymesh.edge_keys(a, b, 5)
    assert keys.dtype == np.int64 and keys.tolist() == [8, 8, 4, 2, 4]
    assert [polymesh.edge_key(int(x), int(y), 5) for x, y in zip(a, b)] == keys.tolist()
    pairs = np.sort(np.column_stack([a, b]), axis=1)
    assert np.array_equal(np.argsort(keys, kind="stable"), np.lexsort((pairs[:, 1], pairs[:, 0])))
    # No int32 overflow for large meshes.
    n = 3_000_000
    assert polymesh.edge_keys(np.int32([n - 1]), np.int32([n - 2]), n)[0] == (n - 2) * n + n - 1
    F = np.array([[0, 1, 2], [2, 1, 3]])
    assert polymesh.face_edge_keys(F, 4).tolist() == [[1, 6, 2], [6, 7, 11]]
    assert polymesh.half_edge_keys(np.array([2, 1]), np.array([1, 2]), 4).tolist() == [9, 6]


def test_find_edges_finds_either_direction_and_reports_missing_pairs():
    E = np.array([[0, 1], [1, 2], [3, 2], [0, 3]], dtype=np.int32)
    lookup = polymesh.edge_lookup(E, 4)
    pairs = np.array([[1, 0], [2, 3], [0, 2], [3, 0], [1, 2], [3, 3]])
    assert polymesh.find_edges(lookup, pairs).tolist() == [0, 2, -1, 3, 1, -1]
    empty = polymesh.edge_lookup(np.zeros((0, 2), np.int32), 4)
    assert polymesh.find_edges(empty, pairs).tolist() == [-1] * 6
    assert polymesh.find_edges(lookup, np.zeros((0, 2), int)).tolist() == []


# --- routing ---------------------------------------------------------------------------------

def quad_grid(n):
    """(n + 1)^2 vertices, n x n quads: (polygons, vertex index of (i, j))."""
    def vid(i, j):
        return i * (n + 1) + j
    return [[vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)] for i in range(n) for j in range(n)], vid


def test_route_edges_on_a_grid_finds_the_shortest_edge_path():
    """Known answers on a quad grid: the pairs that are no edge get a path of real edges from one
    to the other, as long as their grid (Manhattan) distance, none beyond 4 edges."""
    polys, vid = quad_grid(6)
    _, _, _, E, _ = polygon_arrays(polys)
    nv = 49
    lookup = polymesh.edge_lookup(E, nv)
    pairs = np.array([[vid(0, 0), vid(1, 1)], [vid(2, 2), vid(3, 4)], [vid(5, 5), vid(3, 3)],
                      [vid(0, 0), vid(0, 1)], [vid(0, 0), vid(3, 3)]])
    routed, owner = polymesh.route_edges(pairs, E, lookup)
    assert (routed >= 0).all()
    for k, (a, b) in enumerate(pairs.tolist()):
        path = E[routed[owner == k]]
        ia, ja, ib, jb = a // 7, a % 7, b // 7, b % 7
        want = abs(ia - ib) + abs(ja - jb)
        if want > 4:
            assert len(path) == 0
            continue
        assert len(path) == want, (a, b, path)
        # The edges chain from a to b: every vertex but a and b used twice.
        count = np.bincount(path.ravel(), minlength=nv)
        assert count[a] == 1 and count[b] == 1 and set(count[count > 0].tolist()) <= {1, 2}
    # The pair that is an edge already is routed along itself.
    assert E[routed[owner == 3]].tolist() == [[vid(0, 0), vid(0, 1)]]
    # route() alone: a shortest path, None beyond max_depth.
    start, nbr = polymesh.adjacency(E, nv)
    nb = lambda v: nbr[start[v]:start[v + 1]].tolist()  # noqa: E731
    assert len(polymesh.route(vid(0, 0), vid(2, 2), nb)) == 5
    assert polymesh.route(vid(0, 0), vid(3, 3), nb) is None
    assert polymesh.route(vid(0, 0), vid(3, 3), nb, max_depth=6)[-1] == vid(3, 3)


def _merge(A, B):
    """The polygon of polygons A and B (vertex lists, same orientation) joined across their one
    shared edge."""
    shared = set(A) & set(B)
    n = len(A)
    i = next(i for i in range(n) if A[i] in shared and A[(i + 1) % n] in shared)
    a = [A[(i + 1 + k) % n] for k in range(n)]
    j = B.index(A[i])
    b = [B[(j + k) % len(B)] for k in range(len(B))]
    return a + b[1:-1]


def ngon_cube_polygons(n):
    """Rounded cube of hexagons: pairs of grid quads joined across the edge between them."""
    V, quads = shapes.rounded_cube(n, quads=True)
    polys = []
    for side in range(6):
        for a in range(n):
            for b in range(0, n, 2):
                polys.append(_merge(*[list(quads[(side * n + a) * n + bb]) for bb in (b, b + 1)]))
    return V, polys


@pytest.mark.parametrize("polygons", ["quads", "ngons"])
def test_route_edges_take_the_breadth_first_path(polygons):
    """The pairs routed two steps in bulk get the path the breadth-first route() finds (the first
    common neighbour in adjacency order: a quad's diagonal has two), the others route()'s own;
    checked on every vertex pair that is not an edge."""
    V, polys = shapes.rounded_cube(4, quads=True) if polygons == "quads" else ngon_cube_polygons(4)
    _, _, _, E, _ = polygon_arrays(polys)
    E = E.astype(np.int32)
    nv = len(V)
    lookup = polymesh.edge_lookup(E, nv)
    a, b = np.triu_indices(nv, 1)
    pairs = np.column_stack([a, b]).astype(np.int32)
    pairs = pairs[polymesh.find_edges(lookup, pairs) < 0]
    routed, owner = polymesh.route_edges(pairs, E, lookup)
    adjacency = {v: [] for v in range(nv)}
    for i, j in np.concatenate([E, E[:, ::-1]])[np.argsort(np.r_[E[:, 0], E[:, 1]], kind="stable")].tolist():
        adjacency[i].append(j)
    steps = set()
    for k, (i, j) in enumerate(pairs.tolist()):
        path = polymesh.route(i, j, adjacency.__getitem__)
        expected = [] if path is None else polymesh.find_edges(lookup, np.column_stack([path[:-1], path[1:]]))
        assert sorted(routed[owner == k].tolist()) == sorted(list(expected)), (i, j, path)
        steps.add(None if path is None else len(path) - 1)
    assert {2, 3, 4, None} <= steps  # bulk two-step routes, searched ones and unreachable pairs


# --- n-gon triangle repair -------------------------------------------------------------------

def one_polygon(V2d, tris, polygon):
    """MeshArrays of one polygon (its vertex order = its loops) triangulated as ``tris``."""
    V = np.column_stack([np.asarray(V2d, float), np.zeros(len(V2d))])
    F = np.array(tris, dtype=np.int32)
    loop_of = {v: i for i, v in enumerate(polygon)}
    L = np.vectorize(loop_of.get)(F).astype(np.int32)
    E = np.array([[polygon[i], polygon[(i + 1) % len(polygon)]] for i in range(len(polygon))], np.int32)
    return MeshArrays(V, F, L, np.zeros(len(F), np.int32), E)


def test_repair_flips_the_zero_area_ear_of_collinear_corners():
    """A pentagon with vertex 1 in the middle of its side 0-2; the ear (0, 1, 2) has no area. Its
    diagonal 0-2 is flipped with the neighbour (0, 2, 3): (1, 2, 3) and (1, 3, 0)."""
    a = one_polygon([[0, 0], [1, 0], [2, 0], [2, 1], [0, 1]], [[0, 1, 2], [0, 2, 3], [0, 3, 4]], [0, 1, 2, 3, 4])
    with pytest.raises(dgmesh.MeshError):
        dgmesh.validate(a.V, a.F)
    fixed = polymesh.repair_ngon_triangles(a)
    assert fixed.F.tolist() == [[1, 2, 3], [1, 3, 0], [0, 3, 4]]
    assert np.array_equal(fixed.tri_loops, fixed.F)  # corners keep their loops (loop i is vertex i)
    assert (signed_areas(fixed.V, fixed.F) > 0).all()
    dgmesh.validate(fixed.V, fixed.F)
    assert a.F.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]  # the input is not changed
    assert polymesh.repair_ngon_triangles(fixed) is fixed  # nothing left to repair


def test_repair_unfolds_a_triangle_folded_against_its_polygon():
    """A dart (vertex 3 inside triangle 0, 1, 2) cut along the diagonal 0-2 outside it: triangle
    (0, 2, 3) faces against the polygon. Flipping the diagonal to 1-3 unfolds it; without the mesh's
    edges (to tell diagonals from sides) nothing changes."""
    a = one_polygon([[0, 0], [2, 1], [0, 2], [0.5, 1]], [[0, 1, 2], [0, 2, 3]], [0, 1, 2, 3])
    assert (signed_areas(a.V, a.F) > 0).tolist() == [True, False]
    fixed = polymesh.repair_ngon_triangles(a)
    assert fixed.F.tolist() == [[1, 2, 3], [3, 0, 1]]
    assert np.array_equal(fixed.tri_loops, fixed.F)
    assert (signed_areas(fixed.V, fixed.F) > 0).all()
    assert np.isclose(signed_areas(fixed.V, fixed.F).sum(), signed_areas(a.V, a.F).sum())
    no_edges = MeshArrays(a.V, a.F, a.tri_loops, a.tri_poly)
    assert polymesh.repair_ngon_triangles(no_edges) is no_edges


def test_repair_keeps_every_loop_on_the_hexagon_cube():
    """The hexagon cube's n-gons triangulated by fans from each polygon's second corner (at a
    straight run of corners of some hexagons: zero-area fan triangles): repaired, the triangles are
    valid, cover each polygon (same vector area) and keep every loop."""
    V, polys = ngon_cube_polygons(6)
    start, total, lv, E, _ = polygon_arrays(polys)
    L, P = [], []
    for p, (s, t) in enumerate(zip(start.tolist(), total.tolist())):
        for k in range(1, t - 1):
            L.append([s + 1, s + (1 + k) % t, s + (2 + k) % t])
            P.append(p)
    L = np.array(L, np.int32)
    a = MeshArrays(np.asarray(V, float), lv[L].astype(np.int32), L, np.array(P, np.int32), E.astype(np.int32))
    with pytest.raises(dgmesh.MeshError):
        dgmesh.validate(a.V, a.F)
    fixed = polymesh.repair_ngon_triangles(a)
    dgmesh.validate(fixed.V, fixed.F, allow_loose_vertices=False)
    assert np.array_equal(lv[fixed.tri_loops], fixed.F) and np.array_equal(fixed.tri_poly, a.tri_poly)

    def vector_area(x):
        out = np.zeros((len(polys), 3))
        np.add.at(out, x.tri_poly, np.cross(x.V[x.F[:, 1]] - x.V[x.F[:, 0]], x.V[x.F[:, 2]] - x.V[x.F[:, 0]]))
        return out
    assert np.allclose(vector_area(fixed), vector_area(a), atol=1e-9)
    assert len(np.unique(fixed.tri_loops)) == len(lv)


# --- region orientation ----------------------------------------------------------------------

def test_orient_region_turns_the_one_flipped_face_back():
    V, F = shapes.grid(4, 4)
    F = np.asarray(F, np.int32)
    L = np.arange(3 * len(F), dtype=np.int32).reshape(-1, 3)
    bad = F.copy()
    bad[9] = bad[9][::-1]
    a = MeshArrays(np.asarray(V), bad, L.copy(), np.arange(len(F), dtype=np.int32))
    region = np.zeros(len(F), bool)
    region[[8, 9, 10]] = True
    out = polymesh.orient_region(a, region)
    assert np.array_equal(out.F, F)
    assert out.tri_loops[9].tolist() == L[9][::-1].tolist() and np.array_equal(np.delete(out.tri_loops, 9, 0),
                                                                                np.delete(L, 9, 0))
    assert np.array_equal(a.F, bad)  # the input is not changed
    # A region that agrees with its neighbours: the same arrays back.
    good = MeshArrays(np.asarray(V), F, L, a.tri_poly)
    assert polymesh.orient_region(good, region) is good
    # A region flipped whole (its border against the mesh) turns whole.
    flipped = F.copy()
    flipped[region] = flipped[region][:, ::-1]
    assert np.array_equal(polymesh.orient_region(MeshArrays(np.asarray(V), flipped, L, a.tri_poly), region).F, F)


# --- mirror planes ---------------------------------------------------------------------------

def test_flip_off_mirror_planes():
    """An ear of three boundary vertices on the x = 0 plane next to a triangle off it: their shared
    edge flips, and both new triangles face the way the pair did."""
    V = np.array([[0, 0, 0], [0, 1, 0.3], [0, 2, 0], [1, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]])  # (0, 1, 2) lies in the plane
    G = polymesh.flip_off_mirror_planes(V, F, [(0, 1e-4)])
    assert sorted(map(sorted, G.tolist())) == [[0, 1, 3], [1, 2, 3]]
    n = np.cross(V[G[:, 1]] - V[G[:, 0]], V[G[:, 2]] - V[G[:, 0]])
    assert (n[:, 2] < 0).all()  # as the triangle off the plane, (0, 2, 3)
    assert np.array_equal(polymesh.flip_off_mirror_planes(V, F, []), F)
    assert np.array_equal(polymesh.flip_off_mirror_planes(V, F, [(1, 1e-4)]), F)  # not on the y = 0 plane
    assert F.tolist() == [[0, 1, 2], [0, 2, 3]]  # the input is not changed
    # Vertex 1 beyond vertex 2 along the plane: the flipped pair would fold over; left as it is.
    W = np.array([[0, 0, 0], [0, 3, 0.3], [0, 2, 0], [1, 1, 0]], float)
    assert np.array_equal(polymesh.flip_off_mirror_planes(W, F, [(0, 1e-4)]), F)


def test_mirror_plane_bits_and_the_welded_whole():
    V = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [1e-6, 2, 0]])
    assert polymesh.mirror_plane_bits(V, [(0, 1e-5), (1, 1e-5)]).tolist() == [3, 1, 2, 1]
    F = np.array([[0, 2, 1]])
    W, G, (vmask, fmask) = polymesh.mirrored(V[:3], F, (np.array([True, False, True]), np.array([True])),
                                             [(0, 1e-5)])
    # The seam vertices 0 and 1 are shared; vertex 2's image is vertex 3, the image face reversed.
    assert W.tolist() == [[0, 0, 0], [0, 1, 0], [1, 0, 0], [-1, 0, 0]]
    assert G.tolist() == [[0, 2, 1], [1, 3, 0]]
    assert vmask.tolist() == [True, False, True, True] and fmask.tolist() == [True, True]
    assert polymesh.mirrored(V[:3], np.array([[0, 1, 1]]), (None, None), [(0, 1e-5)]) is None  # in the plane
    moved = V[:3] + 0.01
    assert polymesh.on_mirror_planes(moved, V[:3], [(0, 1e-5)])[:, 0].tolist() == [0, 0, 1.01]


def test_split_seam_edges_splits_a_long_fill_edge_on_the_plane():
    """A fan fill of a half hole against the x = 0 plane: its closing edge along the plane (length
    4, the region's other border edges 1.35 on average) is split into 3 pieces, its triangle into a
    fan facing as it did."""
    V = np.array([[0, -2, 0], [0, 2, 0], [1, 1.5, 0], [1.5, 0, 0], [1, -1.5, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    Vs, Fs, region, origin = polymesh.split_seam_edges(V, F, np.ones(3, bool), [(0, 1e-6)])
    assert len(Vs) == 7 and np.allclose(Vs[5:], [[0, -2 / 3, 0], [0, 2 / 3, 0]])
    assert Fs.tolist() == [[0, 5, 2], [0, 2, 3], [0, 3, 4], [5, 6, 2], [6, 1, 2]]
    assert region.all() and len(region) == 5 and origin.tolist() == [0, 1, 2, 0, 0]
    # Off the plane: nothing to split.
    Vo, Fo, _, o = polymesh.split_seam_edges(V + [1, 0, 0], F, np.ones(3, bool), [(0, 1e-6)])
    assert len(Vo) == 5 and np.array_equal(Fo, F) and o.tolist() == [0, 1, 2]


# --- seam charts -----------------------------------------------------------------------------

def test_split_charts_joins_across_edges_and_cuts_at_seams():
    # Two quads sharing the edge 1-4: 0 1 2 / 3 4 5 ... as a strip 0-1-2 over 3-4-5.
    polys = [[0, 1, 4, 3], [1, 2, 5, 4]]
    start, total, lv, E, le = polygon_arrays(polys)
    mask = np.ones(2, bool)
    seam = np.zeros(len(E), bool)
    cls, chart = polymesh.split_charts(start, total, mask, le, seam, lv)
    assert len(chart) == 6 and chart.tolist() == [0] * 6  # one chart, a class per vertex
    assert cls[1] == cls[4] and cls[2] == cls[7]  # loop 1 (vertex 1) ~ loop 4 (vertex 1), 2 ~ 7 (vertex 4)
    seam[polymesh.find_edges(polymesh.edge_lookup(E, 6), [[1, 4]])] = True
    cls, chart = polymesh.split_charts(start, total, mask, le, seam, lv)
    assert len(chart) == 8 and sorted(chart.tolist()) == [0] * 4 + [1] * 4 and cls[1] != cls[4]
    # Unmasked polygons get no class.
    cls, chart = polymesh.split_charts(start, total, np.array([True, False]), le, np.zeros(len(E), bool), lv)
    assert sorted(cls[:4].tolist()) == [0, 1, 2, 3] and cls[4:].tolist() == [-1] * 4 and chart.tolist() == [0] * 4
    # A flipped neighbour runs the shared edge the same way.
    start, total, lv, E, le = polygon_arrays([[0, 1, 4, 3], [4, 5, 2, 1]])
    with pytest.raises(dgmesh.MeshError, match="inconsistent face orientation"):
        polymesh.split_charts(start, total, mask, le, np.zeros(len(E), bool), lv)


# --- attribute transfer ----------------------------------------------------------------------

def test_blend_attributes_and_group_weights():
    values = [("f", np.array([[0.0], [1.0], [2.0]])), ("i", np.array([[5], [6], [7]], np.int32))]
    out = dict(polymesh.blend_attributes(values, [[0, 1], [2, 1]], [[0.25, 0.75], [0.5, 0.5]]))
    assert out["f"].ravel().tolist() == [0.75, 1.5] and out["i"].ravel().tolist() == [6, 7]
    # Sources: vertex 0 in group 1 (0.5), vertex 1 in groups 0 (1.0) and 1 (1.0).
    ev, eg, ew = np.array([1, 0, 1]), np.array([0, 1, 1]), np.array([1.0, 0.5, 1.0])
    vert, group, weight, counted = polymesh.blend_group_weights([[0, 1], [0, 0]], [[0.5, 0.5], [1.0, 0.0]],
                                                                ev, eg, ew, 2)
    assert list(zip(vert.tolist(), group.tolist(), weight.tolist(), counted.tolist())) == [
        (0, 0, 0.5, True), (0, 1, 0.75, True), (1, 1, 0.5, True)]


def test_nearest_sources_are_all_sources_for_a_rim_else_the_nearest():
    """New vertices' point data came from Shepard weights over every vertex of the replaced
    polygons: a dense new x source matrix (4 GB for a 10K-triangle object, OOM beyond). Past a small
    region they use the 16 nearest."""
    rng = np.random.default_rng(0)
    Q, P = rng.random((3000, 3)), rng.random((1000, 3))
    idx = polymesh.nearest_sources(Q, P)
    d2 = ((P[:, None] - Q[None]) ** 2).sum(-1)
    brute = np.argsort(d2, axis=1)[:, :16]
    assert idx.shape == (1000, 16) and np.array_equal(np.sort(idx, 1), np.sort(brute, 1))
    assert (np.diff(np.take_along_axis(d2, idx, 1), axis=1) >= 0).all()  # nearest first
    assert polymesh.nearest_sources(Q[:50], P[:100]).shape == (100, 50)  # a hole's rim: all of it
    calls = []
    knn = lambda q, p, k: calls.append(k) or brute[:, :k]  # noqa: E731
    assert polymesh.nearest_sources(Q, P, k=8, knn=knn).shape == (1000, 8) and calls == [8]


def test_surviving_and_wire_edges():
    E = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    vmap = np.array([0, 1, 1, 2])  # vertex 2 merged into 1
    out_e, in_e = polymesh.surviving_edges(np.array([[1, 2], [0, 1], [2, 0]]), 3, E, vmap)
    assert out_e.tolist() == [1, 0, 2] and in_e.tolist() == [0, 2, 3]  # edge 1-2 collapsed
    assert polymesh.surviving_edges(np.zeros((0, 2), int), 3, E, vmap)[0].tolist() == []
    wire = np.array([True, True, True, False])
    assert polymesh.wire_edges(E, wire, vmap).tolist() == [[0, 1], [1, 2]]


def test_locked_vertices_are_on_seams_and_material_borders():
    # Loops of vertices 0 0 1 1 2 2; vertex 0's UVs differ, vertex 2's materials.
    lv = np.array([0, 0, 1, 1, 2, 2])
    uv = np.array([[0, 0], [0.5, 0], [1, 1], [1, 1], [2, 2], [2, 2]], float)
    mat = np.array([0, 0, 0, 0, 0, 1])
    assert polymesh.locked_vertices(lv, 4, [uv], mat).tolist() == [True, False, True, False]
    assert polymesh.locked_vertices(lv[:0], 2, [], mat[:0]).tolist() == [False, False]


@pytest.mark.parametrize("surface, ratio", [("cube", 5), ("torus", 10)])
def test_moved_vertex_lookup_picks_the_nearest_triangle(surface, ratio):
    """Each moved output vertex reads its UVs in the nearest (clamped projection) of the input
    triangles around the input vertices merged into it, checked one by one: a triangle met through
    several merged corners counts once, the cube's flat sides give ties, and on the torus a few
    vertices are nearest to a triangle with a single corner merged into them."""
    V, F = shapes.rounded_cube(12) if surface == "cube" else shapes.torus(1.0, 0.4, 24, 12)
    V, F = np.asarray(V, dtype=float) * [1.0, 0.7, 0.5], np.asarray(F, dtype=np.int32)
    V2, _, vmap, _, src = dgmesh.decimate(V, F, target_faces=len(F) // ratio, feature_weight=0.0, return_map=True,
                                          return_face_map=True)
    moved = np.any(V2 != V[src], axis=1)
    w, loops, bary = polymesh.moved_vertex_lookup(np.arange(3 * len(F)).reshape(-1, 3), V, F, V2, vmap, moved)
    assert w.tolist() == [x for x in np.unique(vmap[vmap >= 0]) if moved[x]] and len(w) > 20

    def clamped_distance(p, tri):
        a, b, c = V[tri]
        e0, e1, d = b - a, c - a, p - a
        m = np.array([[e0 @ e0, e0 @ e1], [e0 @ e1, e1 @ e1]])
        bv, bw = np.linalg.solve(m, [d @ e0, d @ e1])
        t = np.clip([1 - bv - bw, bv, bw], 0.0, None)
        t /= t.sum()
        return np.linalg.norm(p - t @ V[tri]), t

    corner_map = vmap[F]
    for k, wi in enumerate(w.tolist()):
        best = min(clamped_distance(V2[wi], F[f])[0] for f in np.flatnonzero((corner_map == wi).any(1)))
        face = loops[k, 0] // 3
        assert (corner_map[face] == wi).any() and loops[k].tolist() == list(range(3 * face, 3 * face + 3))
        d, t = clamped_distance(V2[wi], F[face])
        assert d <= best + 1e-12 and np.allclose(bary[k], t, atol=1e-9)


def test_corner_values_follow_their_vertex_across_a_merge():
    """Two triangles (0, 1, 2), (0, 2, 3) of a square, with UVs cut along 0-2 (a seam: vertex 0 and
    2 have a UV per side); vertex 3 merged into 2. The output triangle (face 0) keeps its corners'
    UVs; a corner now at vertex 2 takes vertex 2's UV on its own side of the seam."""
    tri_loops = np.array([[0, 1, 2], [3, 4, 5]])
    loop_vertex = np.array([0, 1, 2, 0, 2, 3])
    uv = np.array([[0, 0], [1, 0], [1, 1], [5, 5], [6, 6], [5, 6]], float)
    # Output: vertices 0, 1, 2 (input 0, 1, 2), one triangle from input face 1 with its corner at 3
    # now at 2, and one from face 0 unchanged.
    F2 = np.array([[0, 2, 2], [0, 1, 2]])
    face_map = np.array([1, 0])
    source_vertex = np.array([0, 1, 2])
    plan = polymesh.corner_plan(tri_loops, loop_vertex, F2, face_map, source_vertex)
    out = polymesh.transfer_corner_values(uv, plan)
    assert out.tolist() == [[5, 5], [6, 6], [6, 6], [0, 0], [1, 0], [1, 1]]
    moved = np.array([False, True, False])
    moved_values = np.array([[0, 0], [9, 9], [0, 0]], float)
    out = polymesh.transfer_corner_values(uv, plan, moved_values, moved)
    assert out[4].tolist() == [9, 9] and out[3].tolist() == [0, 0]
    ints = np.arange(6, dtype=np.int32)[:, None]
    assert polymesh.decimated_corner_values(ints, plan, None, None, 3).ravel().tolist() == [3, 4, 4, 0, 1, 2]


# --- corners of triangles that replace polygons ---------------------------------------------

def test_corner_weights_are_inverse_squared_distances_and_exact_at_corners():
    Q = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)  # a unit square
    P = np.array([[[0.5, 0, 0], [1, 1, 0], [0.5, 0.5, 0]]])
    W = polymesh.corner_weights(P, Q)
    assert W.shape == (1, 3, 4)
    # Distances 0.5, 0.5, sqrt(1.25), sqrt(1.25): weights 4, 4, 0.8, 0.8 over 9.6.
    assert np.allclose(W[0, 0], [5 / 12, 5 / 12, 1 / 12, 1 / 12])
    assert W[0, 1].tolist() == [0, 0, 1, 0]  # on a corner: that corner's alone
    assert np.allclose(W[0, 2], 0.25)


def test_interpolate_corners_blends_floats_and_takes_the_nearest_integer():
    """A quad (vertices 0-3, loops 0-3) replaced by a fan around its centre (vertex 4) and a
    triangle (vertices 1, 5, 2, loops 4-6) kept as it is: polygons of two sizes."""
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0], [2, 0.5, 0]], float)
    loop_start, loop_total = np.array([0, 4]), np.array([4, 3])
    loop_vertex = np.array([0, 1, 2, 3, 1, 5, 2])
    tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [1, 5, 2]])
    src = np.array([0, 0, 0, 0, 1])
    uv = V[loop_vertex, :2] + np.array([[0, 0]] * 4 + [[10, 0]] * 3)  # the triangle's UVs apart
    ids = np.array([[10], [11], [12], [13], [20], [21], [22]], dtype=np.int32)
    for chunk in (1 << 20, 3):  # all rows at once, or one at a time
        (k1, cu), (k2, ci) = polymesh.interpolate_corners(V, tris, src, loop_start, loop_total, loop_vertex,
                                                          [("uv", uv), ("id", ids)], chunk=chunk)
        assert (k1, k2) == ("uv", "id") and cu.shape == (5, 3, 2) and ci.dtype == np.int32
        assert np.allclose(cu[0], [[0, 0], [1, 0], [0.5, 0.5]])  # the centre: the mean of four
        assert np.allclose(cu[2], [[1, 1], [0, 1], [0.5, 0.5]])
        assert np.allclose(cu[4], [[11, 0], [12, 0.5], [11, 1]])  # the triangle's own loops
        assert ci[:, :, 0].tolist() == [[10, 11, 10], [11, 12, 10], [12, 13, 10], [13, 10, 10], [20, 21, 22]]


# --- measures of a result --------------------------------------------------------------------

def test_moved_count_ignores_rounding():
    V0 = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2]], float)
    V = V0.copy()
    V[1, 0] += 1e-6   # moved
    V[2, 1] += 1e-12  # rounding: below 1e-9 of the size 2
    V[3] = [0, 0, 1]  # moved
    assert polymesh.moved_count(V, V0) == 2
    assert polymesh.moved_count(V0, V0) == 0
    assert polymesh.moved_count(np.zeros((0, 3)), np.zeros((0, 3))) == 0


def test_min_angle_deg():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 3 ** 0.5 / 2, 0]])
    assert polymesh.min_angle_deg(V, np.array([[0, 1, 2]])) == pytest.approx(45.0)
    assert polymesh.min_angle_deg(V, np.array([[0, 1, 3]])) == pytest.approx(60.0)
    assert polymesh.min_angle_deg(V, np.array([[0, 1, 3], [0, 1, 2]])) == pytest.approx(45.0)
    assert polymesh.min_angle_deg(V, np.zeros((0, 3), int)) == 0.0


def test_nearest_output_sends_a_removed_vertex_to_the_nearest_new_one():
    ids = np.array([10, 11, 12])  # the region's mesh vertices
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)
    V_out = np.array([[1.9, 0, 0], [0.2, 0, 0], [1.2, 0, 0]])
    nearest = polymesh.nearest_output(V_out, ids, V, np.array([100, 101, 102]))
    assert [int(nearest(v)) for v in (10, 11, 12)] == [101, 102, 100]
    with pytest.raises(KeyError):
        nearest(13)  # not in the region


# --- crest lines as mesh edges ---------------------------------------------------------------

def quad_arrays(V, quads):
    """MeshArrays of a quad mesh: two triangles per quad, the quads' own edges (no diagonals)."""
    Q = np.asarray(quads)
    F = np.concatenate([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]]).astype(np.int32)
    tri_poly = np.r_[np.arange(len(Q)), np.arange(len(Q))].astype(np.int32)
    edges = np.unique(np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], -1).reshape(-1, 2), axis=1), axis=0)
    return MeshArrays(np.asarray(V, float), F, np.zeros_like(F), tri_poly, edges.astype(np.int32))


def test_crest_edges_follow_the_rounded_edges_of_a_cube_on_its_quad_edges():
    V, quads = shapes.rounded_cube(12, 0.3, quads=True)
    arrays = quad_arrays(V, quads)
    lines = dgmesh.crest_lines(arrays.V, arrays.F)
    assert len(lines) > 0 and lines.is_ridge.all()  # ridges only
    ridge, valley = polymesh.crest_edges(lines, arrays)
    assert ridge.shape == valley.shape == (len(arrays.edges),)
    assert not valley.any()
    # Every marked edge lies on a rounded edge (two coordinates in the rounding, |c| > 1 - r), and
    # each of the 12 rounded edges is followed along most of its length.
    on = (np.abs(arrays.V) > 0.7 - 1e-9).sum(1) >= 2
    E = arrays.edges[ridge]
    assert on[E].all()
    assert ridge.sum() >= 12 * 6
    # Where a line crosses a quad's diagonal, the marked quad edges are routed around it: the
    # marked edges form paths without gaps, whose only ends are the lines' ends.
    degree = np.bincount(E.ravel(), minlength=len(V))
    assert np.count_nonzero(degree == 1) <= 2 * len(lines)


def test_crest_edges_of_no_lines_mark_nothing():
    V, F = shapes.grid(4, 4)
    E = np.unique(np.sort(F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0).astype(np.int32)
    arrays = MeshArrays(V, F, np.zeros_like(F), np.arange(len(F), dtype=np.int32), E)
    ridge, valley = polymesh.crest_edges(dgmesh.crest_lines(V, F), arrays)
    assert ridge.shape == (len(E),) and not ridge.any() and not valley.any()
