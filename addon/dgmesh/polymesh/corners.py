"""Corner values (UVs, colours) of new triangles: of a re-triangulated region, from the input
triangles each new vertex lies on (``dgmesh.remesh_full``'s source_face / source_bary), islands of a
UV map kept apart across seams (:func:`island_corners`); of the triangles that replace polygons
(Fair with Subdivisions), blended over the corners of the polygon each replaces
(:func:`interpolate_corners`)."""

import numpy as np

from ..unwrapping import chart_labels
from .edges import edge_keys


def shared_edges(F) -> tuple:
    """The interior edges of triangles F as (face a, face b, and the corners of each face at the
    edge's two ends: ka_u, kb_u, ka_v, kb_v), u -> v the edge's direction in face a: the same for
    every corner layer (computed once: per layer it was half of the corner work of a 1M-triangle
    Remesh)."""
    nf = len(F)
    e_f = np.repeat(np.arange(nf), 3)
    e_i = np.tile(np.arange(3), nf)
    u, v = F[e_f, e_i], F[e_f, (e_i + 1) % 3]
    key = edge_keys(u, v, F.max() + 1)
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order[1:]] == key[order[:-1]])
    a, b = order[same], order[same + 1]  # half-edges of the same edge in faces fa, fb
    fa, fb = e_f[a], e_f[b]
    ua, va = u[a], v[a]

    def corner_of(f, x):
        return np.argmax(F[f] == x[:, None], axis=1)

    return fa, fb, corner_of(fa, ua), corner_of(fb, ua), corner_of(fa, va), corner_of(fb, va)


def island_corners(V, F, C, r, shared=None) -> np.ndarray:
    """Corner values (m_out, 3, k) of the output triangles from the input's corner values C (nf, 3,
    k) on the input triangles (V, F). ``r``: the remesh result (its V, F, source_face,
    source_bary); ``shared``: :func:`shared_edges` of F when already made.

    Each output vertex lies on an input triangle (source_face / source_bary). Where the input's
    corner values jump across an edge (a UV seam: the islands on either side), an output triangle
    whose corners lie on different islands takes all three from one island, its home (the island of
    two of its corners, else the first's): a corner elsewhere gets the home triangle's affine map
    extended to its position. So does a corner whose own value is farther from that extension than
    the triangle's extent in the map (across a seam that ends inside the region, whose two sides
    are one island). Blending each corner on its own side gave such triangles corners on both sides
    of the seam (a triangle stretched across the UV map)."""
    nf = len(F)
    # Islands: triangles joined across edges whose two shared corners carry the same values.
    fa, fb, ka_u, kb_u, ka_v, kb_v = shared_edges(F) if shared is None else shared
    tol = 1e-6 * max(1.0, float(np.abs(C).max(initial=0.0)))
    cont = (np.abs(C[fa, ka_u] - C[fb, kb_u]).max(-1) <= tol) & (np.abs(C[fa, ka_v] - C[fb, kb_v]).max(-1) <= tol)
    lab = chart_labels(nf, np.stack([fa[cont], fb[cont]], 1))
    T = r.F
    s = r.source_face[T]  # (m, 3) source triangle of each corner
    val = (r.source_bary[T][..., None] * C[s]).sum(2)  # (m, 3, k): each corner in its own island
    isl = lab[s]
    home = np.where((isl[:, 1] == isl[:, 2]) & (isl[:, 0] != isl[:, 1]), s[:, 1], s[:, 0])
    # Every corner through the home triangle's affine map (barycentric coordinates of its position
    # projected on that triangle's plane, possibly negative).
    h = np.repeat(home, 3)
    P = r.V[T.ravel()]
    A, B, D = V[F[h, 0]], V[F[h, 1]], V[F[h, 2]]
    e0, e1, d = B - A, D - A, P - A
    d00, d01, d11 = (e0 * e0).sum(1), (e0 * e1).sum(1), (e1 * e1).sum(1)
    d20, d21 = (d * e0).sum(1), (d * e1).sum(1)
    det = d00 * d11 - d01 ** 2
    den = np.where(np.abs(det) > 0, det, 1.0)
    wb = (d11 * d20 - d01 * d21) / den
    wc = (d00 * d21 - d01 * d20) / den
    ext = (np.stack([1 - wb - wc, wb, wc], 1)[..., None] * C[h]).sum(1).reshape(val.shape)
    # Another island, or (a seam that ends inside the region joins its sides into one island) a
    # jump larger than the triangle's own extent in the map: the corner is across a seam.
    size = np.linalg.norm(ext[:, [0, 1, 2]] - ext[:, [1, 2, 0]], axis=2).max(1, keepdims=True)
    jump = np.linalg.norm(val - ext, axis=2) > size + 1e-12
    off = (isl != lab[home][:, None]) | jump
    val[off] = ext[off]
    return val


def corner_weights(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Weights (t, 3, k) of new corners P (t, 3, 3) over the k corners Q (t, k, 3) of the polygon
    each triangle replaces: inverse squared distances, normalised; all on the first corner at the
    same place (exact at shared vertices)."""
    d = np.linalg.norm(P[:, :, None, :] - Q[:, None, :, :], axis=-1)
    exact = d < 1e-12
    w = 1.0 / np.maximum(d, 1e-12) ** 2
    hit = np.nonzero(exact.any(-1))
    w[hit] = 0.0
    w[hit + (exact[hit].argmax(-1),)] = 1.0
    return w / w.sum(-1, keepdims=True)


def interpolate_corners(V: np.ndarray, tris: np.ndarray, src: np.ndarray, loop_start: np.ndarray,
                        loop_total: np.ndarray, loop_vertex: np.ndarray, layers: list[tuple[object, np.ndarray]],
                        chunk: int = 1 << 20) -> list[tuple[object, np.ndarray]]:
    """Corner data (UVs, colours, generic attributes) of new triangles from the polygons they
    replace: corner j of triangle t (at V[tris[t, j]]) blends the corners of polygon src[t] (its
    loops from loop_start/loop_total, their vertices loop_vertex, as read before the write) by
    :func:`corner_weights`; integers and booleans come from the nearest corner. ``layers``: [(key,
    (loops, k) values)]; returns [(key, (t, 3, k) values)]. All triangles at once, grouped by polygon
    size: with a Python loop per face, writing 25K new faces with 7 corner layers took 1.6 s, now
    0.2 s (BMLoop.copy_from_face_interp would do it per face but fails on Blender 3.4 with Python
    3.11). ``chunk`` bounds the corners blended at once (memory for large n-gons)."""
    out = [np.zeros((len(tris), 3, C.shape[1]), C.dtype if C.dtype.kind in "ib" else float) for _, C in layers]
    size = loop_total[src]
    for k in np.unique(size).tolist():
        rows_k = np.flatnonzero(size == k)
        for s in range(0, len(rows_k), max(1, chunk // (3 * k))):  # bounded memory for large n-gons
            rows = rows_k[s:s + max(1, chunk // (3 * k))]
            loops = loop_start[src[rows]][:, None] + np.arange(k)
            W = corner_weights(V[tris[rows]], V[loop_vertex[loops]])
            near = W.argmax(-1)
            for o, (_key, C) in zip(out, layers):
                Cs = C[loops]  # (g, k, width)
                if C.dtype.kind in "ib":
                    o[rows] = Cs[np.arange(len(rows))[:, None], near]
                else:
                    o[rows] = np.einsum("gjk,gkw->gjw", W, Cs)
    return [(key, o) for (key, _C), o in zip(layers, out)]
