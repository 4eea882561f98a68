"""Carrying a polygon mesh's data onto its decimated triangles (``dgmesh.decimate`` with
``return_map`` and ``return_face_map``): which input vertices, corners and edges each output one
takes its data from.

Names used below: ``vertex_map`` (input vertex -> output vertex, -1 for loose vertices),
``face_map`` (output triangle -> input triangle it was), ``source_vertex`` (output vertex -> input
vertex it was), ``moved`` (per output vertex: moved to its quadric optimum), ``tri_loops`` (the
input triangles' loops), ``loop_vertex`` (the input loops' vertices).
"""

from typing import List, Optional, Tuple

import numpy as np

from .edges import edge_keys, edge_lookup, find_edges
from .mesh import ranges

MovedLookup = Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]]  # see moved_vertex_lookup


def locked_vertices(loop_vertex, n_vertices: int, corner_values: List[np.ndarray], loop_group) -> np.ndarray:
    """Vertices decimation must keep in place: those whose corners hold different values of any of
    ``corner_values`` ((n_loops, k) each: UV maps, more than 1e-6 apart: on a seam) or of
    ``loop_group`` (per loop, e.g. its polygon's material: on a border). So seams and borders stay
    exact and every decimated face keeps corners of one UV island."""
    locked = np.zeros(n_vertices, dtype=bool)
    if len(loop_vertex):
        order = np.argsort(loop_vertex, kind="stable")
        sv = loop_vertex[order]
        first = order[np.searchsorted(sv, sv)]  # a loop of the same vertex, per sorted loop
        for uv in corner_values:
            differs = np.abs(uv[order] - uv[first]).max(1) > 1e-6
            locked[sv[differs]] = True
        locked[sv[loop_group[order] != loop_group[first]]] = True
    return locked


def surviving_edges(out_edges, n_out: int, in_edges, vertex_map) -> Tuple[np.ndarray, np.ndarray]:
    """(output edges, input edges) of the input edges (e, 2) that survive the decimation: both ends
    kept and still joined by one of ``out_edges`` (output mesh of ``n_out`` vertices)."""
    out = np.asarray(out_edges).reshape(-1, 2)
    a, b = (vertex_map[in_edges[:, k]].astype(np.int64) for k in (0, 1))
    if not len(out):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    idx = find_edges(edge_lookup(out, n_out), np.column_stack([a, b]))
    hit = np.flatnonzero((a >= 0) & (b >= 0) & (a != b) & (idx >= 0))
    return idx[hit], hit.astype(np.int64)


def wire_edges(in_edges, wire, vertex_map) -> np.ndarray:
    """The wire edges (``wire``: bool per input edge, edges of no face) on the output vertices
    (every input vertex mapped, loose ones included): unique (k, 2) pairs, lower index first, none
    collapsed to a point."""
    pairs = vertex_map[in_edges[wire]]
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    n = int(pairs.max()) + 1 if len(pairs) else 1
    return np.column_stack(np.divmod(np.unique(edge_keys(pairs[:, 0], pairs[:, 1], n)), n))


def vertex_sources(source_vertex, lookup: MovedLookup, loop_vertex, loose, n_surface: int
                   ) -> Tuple[np.ndarray, np.ndarray]:
    """Where each output vertex takes its point data and vertex-group weights: (n_out, 3) input
    vertices and weights, as ``blend_attributes`` takes them. A vertex that kept its place takes its
    source vertex's; one moved to its quadric optimum blends the nearest input triangle's by its
    barycentrics (:func:`moved_vertex_lookup`, as its UVs); the loose vertices ``loose`` (input
    indices, output after the ``n_surface`` surface vertices) keep their own."""
    src = np.concatenate([np.asarray(source_vertex[:n_surface], dtype=np.int64), loose])
    idx = np.repeat(src[:, None], 3, axis=1)
    w = np.zeros(idx.shape)
    w[:, 0] = 1.0
    if lookup is not None:
        moved_out, loops, bary = lookup
        idx[moved_out] = loop_vertex[loops]
        w[moved_out] = bary
    return idx, w


def moved_vertex_lookup(tri_loops, V, F, V2, vertex_map, moved) -> MovedLookup:
    """Where each moved output vertex (quadric optimum) reads its UVs: the nearest input triangle
    (distance to its clamped projection; the first on a tie) around the input vertices merged into
    it, and its barycentrics there. Those vertices are never locked (off UV seams), so their
    triangles lie in one UV island. (output vertices (ascending), (k, 3) input loops, (k, 3)
    barycentrics), or None; the same for every UV map (once per mesh: per map it was 3.2 s of a
    1M-triangle decimation)."""
    merged = np.flatnonzero((vertex_map >= 0) & moved[np.maximum(vertex_map, 0)])
    if merged.size == 0:
        return None
    # Candidates grouped by output vertex (its input vertices in ascending order, each with its
    # triangles in corner order), so the nearest per group needs no sort of them all.
    merged = merged[np.argsort(vertex_map[merged], kind="stable")]
    fv = F.ravel()
    order = np.argsort(fv, kind="stable")
    start = np.searchsorted(fv[order], np.arange(len(V) + 1))
    count = start[merged + 1] - start[merged]
    pos = ranges(start[merged], count)
    face = order[pos] // 3
    v = np.repeat(merged, count)
    w = vertex_map[v]
    # A triangle with several corners merged into w is measured once, from its lowest one (45% of
    # the candidates at 1M triangles were such repeats).
    corners = F[face]
    first_time = ~((vertex_map[corners] == w[:, None]) & (corners < v[:, None])).any(1)
    face, w = face[first_time], w[first_time]
    # Coordinates as rows (3, k): the per-candidate sums are whole-row operations (sum(1) over
    # (k, 3) was a third of the time), added in sum(1)'s order.
    Vt = np.ascontiguousarray(V.T)
    A, B, C = (Vt[:, F[face, k]] for k in range(3))
    p = np.ascontiguousarray(V2.T)[:, w]

    def dot(x, y):
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]

    # Barycentrics of p projected onto the triangle's plane, clamped into the triangle.
    e0, e1, d = B - A, C - A, p - A
    d00, d01, d11, d20, d21 = dot(e0, e0), dot(e0, e1), dot(e1, e1), dot(d, e0), dot(d, e1)
    det = d00 * d11 - d01 * d01
    den = np.where(np.abs(det) > 0, det, 1.0)
    bv, bw = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    bary = np.clip(np.stack([1 - bv - bw, bv, bw]), 0.0, None)
    bary /= np.maximum(bary[0] + bary[1] + bary[2], 1e-300)
    r = p - (bary[0] * A + bary[1] * B + bary[2] * C)
    dist = dot(r, r)
    dist[np.isnan(dist)] = np.inf  # a sliver triangle's: last choice
    # Per output vertex the nearest triangle, the first one on a tie.
    starts = np.r_[0, np.flatnonzero(np.diff(w)) + 1]
    nearest = np.flatnonzero(dist == np.repeat(np.minimum.reduceat(dist, starts), np.diff(np.r_[starts, len(w)])))
    first = nearest[np.r_[True, w[nearest][1:] != w[nearest][:-1]]]
    return w[first], tri_loops[face[first]], np.ascontiguousarray(bary[:, first].T)


def moved_vertex_values(values, lookup: MovedLookup, n: int) -> np.ndarray:
    """UV (or other corner values, (n_loops, k)) of each of the n output vertices that
    :func:`moved_vertex_lookup` places, interpolated by its barycentrics (zero elsewhere)."""
    out = np.zeros((n, values.shape[1]))
    if lookup is not None:
        w, loops, bary = lookup
        out[w] = (bary[:, :, None] * values[loops]).sum(1)
    return out


def corner_plan(tri_loops, loop_vertex, F2, face_map, source_vertex) -> tuple:
    """What carrying corner values to the decimated triangles F2 needs that does not depend on the
    values (once per decimation, not per UV map or corner layer): (input loop of each output corner,
    the corners now at another vertex, for each of those its candidates' group and loops, output
    vertex of each corner). Output triangle j is input triangle face_map[j] with some corners now
    at a merged vertex."""
    ref = tri_loops[face_map].ravel()  # input loops of the output corners
    src = source_vertex[F2].ravel()    # input vertex now at each corner
    changed = np.flatnonzero(loop_vertex[ref] != src)
    order = np.argsort(loop_vertex, kind="stable")
    start = np.searchsorted(loop_vertex[order], np.arange(int(loop_vertex.max(initial=-1)) + 2))
    v = src[changed]
    count = start[v + 1] - start[v]
    group = np.repeat(np.arange(changed.size), count)
    return ref, changed, group, order[ranges(start[v], count)], F2.ravel()


def transfer_corner_values(values, plan, moved_values=None, moved=None) -> np.ndarray:
    """UVs (or other corner values, (n_loops, k)) for the corners of the decimated triangles
    ((3 m2, k) float64), by :func:`corner_plan`. A corner that kept its vertex keeps its own value. A
    corner now at another surviving vertex takes one of that vertex's original corner values: the
    one nearest to the corner's old value, i.e. the one on the same side of any seam. Vertices that
    moved (``moved``, per output vertex) take ``moved_values`` (per output vertex)."""
    ref, changed, group, cand, corner_vertex = plan
    flat = values[ref].astype(np.float64)
    if changed.size:
        dist = ((values[cand] - flat[changed][group]) ** 2).sum(1)
        pick = np.lexsort((dist, group))
        first = pick[np.r_[0, np.flatnonzero(np.diff(group[pick])) + 1]] if pick.size else pick
        flat[changed[group[first]]] = values[cand[first]]
    if moved is not None:
        at_moved = moved[corner_vertex]
        flat[at_moved] = moved_values[corner_vertex[at_moved]]
    return flat


def decimated_corner_values(values, plan, lookup: MovedLookup, moved, n_out: int) -> np.ndarray:
    """Corner values (n_loops, k) of the input (UVs, colours, normals, integer attributes) for the
    decimated triangles' corners, (3 m2, k): :func:`transfer_corner_values`, moved vertices
    interpolated in their :func:`moved_vertex_lookup` triangle (integers and booleans: the value of
    its corner with the largest barycentric, in their own dtype)."""
    discrete = values.dtype.kind in "ib"
    at_moved = moved_vertex_values(values.astype(float), lookup, n_out)
    if discrete and lookup is not None:  # no blend: the corner with the largest barycentric
        w, loops, bary = lookup
        at_moved[w] = values[loops[np.arange(len(w)), bary.argmax(1)]]
    out = transfer_corner_values(values.astype(float), plan, at_moved, moved)
    return out.astype(values.dtype) if discrete else out


def largest_source_values(values, idx, w) -> np.ndarray:
    """Per output vertex the largest of ``values`` (per input vertex) over its sources
    (:func:`vertex_sources`) with a weight: how vertex creases and bevel weights merge."""
    return np.where(w > 0, values[idx], 0.0).max(1)
