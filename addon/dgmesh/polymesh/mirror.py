"""A half mesh closed by mirror planes (Blender's Mirror modifier with Merge on): which vertices lie
on a plane, the welded whole, and keeping triangles out of the planes.

``axes`` is a list of (axis, tolerance): the plane x[axis] = 0 and the distance within which a
vertex is on it (``bridge.mirror_axes`` reads them from the modifier).
"""

from typing import Optional, Sequence, Tuple

import numpy as np

from .edges import edge_key, edge_keys, half_edge_keys

Axes = Sequence[Tuple[int, float]]


def mirror_plane_bits(V, axes: Axes) -> np.ndarray:
    """Per vertex, bit k set when it lies on the mirror plane of axis k."""
    bits = np.zeros(len(V), np.int32)
    for k, tol in axes:
        bits[np.abs(V[:, k]) <= tol] |= 1 << k
    return bits


def on_mirror_planes(V: np.ndarray, V0, axes: Axes) -> np.ndarray:
    """Vertices of the base mesh (V's first rows) that were on a mirror plane in V0 stay exactly
    there: V, changed in place."""
    for k, tol in axes:
        seam = np.flatnonzero(np.abs(V0[:, k]) <= tol)
        V[seam, k] = V0[seam, k]
    return V


def flip_off_mirror_planes(V, F, axes: Axes) -> np.ndarray:
    """A triangle with its three corners on a mirror plane lies in the plane, on its mirror twin:
    the mirrored mesh tears there (a kept boundary along the plane gives a few, from three boundary
    vertices in a row). Each such triangle's edge shared with a triangle off the plane is flipped,
    when the two new triangles face the way the pair did. Returns the new F (a copy)."""
    F = np.array(F)
    on = mirror_plane_bits(V, axes)
    bad = np.flatnonzero(on[F[:, 0]] & on[F[:, 1]] & on[F[:, 2]])
    if not len(bad):
        return F
    n = len(V)
    keys = half_edge_keys(F, np.roll(F, -1, axis=1), n).ravel()  # half-edge a -> b of face i // 3
    order = np.argsort(keys)
    made = {}  # half-edges of flipped faces (the sorted keys are stale for them)

    def face_of(a, b):  # the face with half-edge a -> b, or None
        k = a * n + b
        i = np.searchsorted(keys, k, sorter=order)
        for f in (made.get((a, b)), int(order[i]) // 3 if i < len(keys) and keys[order[i]] == k else None):
            if f is not None and any(F[f, j] == a and F[f, (j + 1) % 3] == b for j in range(3)):
                return f
        return None

    def normal(a, b, c):
        return np.cross(V[b] - V[a], V[c] - V[a])

    for t in bad:  # a handful: a loop over them
        for k in range(3):
            a, b, c = (int(F[t, (k + j) % 3]) for j in range(3))
            g = face_of(b, a)
            if g is None:
                continue
            d = int(F[g].sum()) - a - b
            if on[a] & on[b] & on[d] or face_of(c, d) is not None or face_of(d, c) is not None:
                continue
            m = normal(b, a, d)  # the neighbour off the plane: the side the surface faces
            if normal(a, d, c) @ m <= 0 or normal(d, b, c) @ m <= 0:
                continue
            F[t], F[g] = (a, d, c), (d, b, c)
            made.update({(a, d): t, (d, c): t, (c, a): t, (d, b): g, (b, c): g, (c, d): g})
            break
    return F


def mirrored(V, F, masks, axes: Axes) -> Optional[tuple]:
    """The base mesh reflected across each mirror plane and welded at the plane, as the Mirror
    modifier shows it: (V, F, masks) with the base mesh's vertices first; vertices on a plane are
    shared by both halves; per-vertex and per-face masks ((vmask, fmask), each may be None) are
    repeated. None when a face lies in a plane (it would be doubled)."""
    vmask, fmask = masks
    for k, tol in axes:
        seam = np.abs(V[:, k]) <= tol
        if seam[F].all(axis=1).any():
            return None
        n = len(V)
        image = np.where(seam, np.arange(n), n + np.cumsum(~seam) - 1)
        R = V[~seam].copy()
        R[:, k] = -R[:, k]
        V = np.concatenate([V, R])
        F = np.concatenate([F, image[F][:, ::-1]])  # a reflection turns the orientation
        vmask = None if vmask is None else np.concatenate([vmask, vmask[~seam]])
        fmask = None if fmask is None else np.concatenate([fmask, fmask])
    return V, F, (vmask, fmask)


def split_seam_edges(V, F, region, axes: Axes) -> tuple:
    """Edges of the region (``region``: bool per triangle) lying on a mirror plane that the half
    alone holds (a hole next to the plane, filled: its closing edge runs along the plane) split into
    pieces as long as the region's other border edges, their triangles into fans. In the welded
    whole such an edge is inside the patch, and the refinement, which never splits the region's
    border, would keep it whole (a crease along the plane). Returns (V, F, region, face_origin);
    new vertices and rows follow."""
    n = len(V)
    key = edge_keys(F, F[:, [1, 2, 0]], n)  # (m, 3) side keys
    uniq, count = np.unique(key, return_counts=True)
    boundary = set(uniq[count == 1].tolist())
    on = np.zeros(len(V), bool)
    for k, tol in axes:
        on |= np.abs(V[:, k]) <= tol
    # The region's border: edges of one region face only (the fill's diagonals are longer).
    rkey, rcount = np.unique(key[region], return_counts=True)
    rkey = np.column_stack(np.divmod(rkey, n))  # back to (min, max) pairs
    other = rkey[(rcount == 1) & ~(on[rkey[:, 0]] & on[rkey[:, 1]])]
    if not len(other):
        return V, F, region, np.arange(len(F))
    h = float(np.linalg.norm(V[other[:, 0]] - V[other[:, 1]], axis=1).mean())
    V, rows, origin, reg = list(V), list(F.tolist()), list(range(len(F))), list(region)
    for f in np.flatnonzero(region):
        a, b, c = rows[f]
        for (u, v, w) in ((a, b, c), (b, c, a), (c, a, b)):
            if not (on[u] and on[v] and edge_key(u, v, n) in boundary):
                continue
            pieces = int(round(np.linalg.norm(V[u] - V[v]) / h))
            if pieces < 2:
                break
            ids = [u] + [len(V) + i for i in range(pieces - 1)] + [v]
            V += [V[u] + (V[v] - V[u]) * (i / pieces) for i in range(1, pieces)]
            fan = [[ids[i], ids[i + 1], w] for i in range(pieces)]
            rows[f] = fan[0]
            rows += fan[1:]
            origin += [f] * (pieces - 1)
            reg += [True] * (pieces - 1)
            break  # a fill triangle has at most one edge along the plane worth splitting
    return np.array(V), np.array(rows, dtype=F.dtype), np.array(reg, bool), np.array(origin)
