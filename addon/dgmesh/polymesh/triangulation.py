"""Triangulations of polygons: repairing n-gon triangulations the native library would reject, and
orienting a region's triangles like their neighbours."""

import dataclasses

import numpy as np

from .edges import edge_key, edge_keys, face_edge_keys
from .mesh import MeshArrays


def repair_ngon_triangles(arrays: MeshArrays, rel_area: float = 1e-12, max_rounds: int = 8) -> MeshArrays:
    """Re-triangulates n-gons whose loop triangulation the native library would reject.

    Blender's ear clipping may cut an "ear" of three collinear corners (an n-gon with a vertex in
    the middle of a straight side, e.g. after dissolving edges): a zero-area triangle. Two n-gons
    sharing two consecutive sides (a valence-2 vertex between them) may both cut the ear at that
    vertex: the same triangle twice, back to back. Each such ear (a, b, c), b the corner whose two
    sides are polygon sides, shares its diagonal with another triangle (a, c, d) of its polygon;
    flipping that diagonal gives (b, c, d) and (b, d, a). Rounds repeat for runs of such corners.
    With the mesh's edges (``arrays.edges``), triangles folded against their polygon are flipped
    too (:func:`unfold_ngon_triangles`).
    Triangles, their loops and polygons stay consistent; ``arrays`` is not changed. Returns new
    :class:`MeshArrays` (the same object when nothing needed repair); what cannot be repaired is
    left for validation to report.
    """
    V, F, L, P = arrays.V, arrays.F.copy(), arrays.tri_loops.copy(), arrays.tri_poly
    if len(F) == 0:
        return arrays
    diag2 = float(((V.max(0) - V.min(0)) ** 2).sum())
    tol = rel_area * max(diag2, np.finfo(float).tiny)
    nv = np.int64(len(V))
    count = np.bincount(P, minlength=int(P.max()) + 1)
    multi = np.flatnonzero(count[P] > 1)  # triangles of n-gons (quads included): the only suspects
    if multi.size == 0:
        return arrays
    real = None  # the mesh's edge keys, a set made only when something needs repair (0.3 s at 1M)

    def area(f):  # twice the area, of (k, 3) index rows
        return np.linalg.norm(np.cross(V[f[:, 1]] - V[f[:, 0]], V[f[:, 2]] - V[f[:, 0]]), axis=1)

    def is_real(x, y):
        return real is not None and edge_key(x, y, nv) in real

    changed = False
    for _ in range(max_rounds):
        bad = np.zeros(len(F), bool)
        bad[multi] = area(F[multi]) <= 2 * tol
        key = np.sort(F.astype(np.int64), axis=1) @ np.array([nv * nv, nv, 1], dtype=np.int64)  # per triangle
        _, first = np.unique(key, return_index=True)
        dup = np.ones(len(F), bool)
        dup[first] = False  # every copy after the first
        bad = np.flatnonzero((bad | dup) & (count[P] > 1))  # triangles of n-gons only
        if bad.size == 0:
            break
        if real is None and arrays.edges is not None and len(arrays.edges):
            real = set(edge_keys(arrays.edges[:, 0], arrays.edges[:, 1], nv).tolist())
        members = {}
        for t in np.flatnonzero(np.isin(P, np.unique(P[bad]))).tolist():
            members.setdefault(int(P[t]), []).append(t)
        progress = False
        for t in bad.tolist():
            f = F[t].tolist()
            # b: the ear corner (its two sides are polygon sides, the third side a diagonal);
            # without edges, the corner opposite the longest side (the middle of collinear ones).
            ears = [k for k in range(3) if is_real(f[k], f[(k + 1) % 3]) and is_real(f[k], f[(k + 2) % 3])
                    and not is_real(f[(k + 1) % 3], f[(k + 2) % 3])]
            if len(ears) == 1:
                k = ears[0]
            else:
                k = int(np.argmax([np.linalg.norm(V[f[(k + 2) % 3]] - V[f[(k + 1) % 3]]) for k in range(3)]))
            b, c, a = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
            lb, lc, la = int(L[t, k]), int(L[t, (k + 1) % 3]), int(L[t, (k + 2) % 3])
            for u in members[int(P[t])]:
                if u == t:
                    continue
                g = F[u].tolist()
                # The neighbour holds the directed edge a -> c.
                j = next((j for j in range(3) if g[j] == a and g[(j + 1) % 3] == c), None)
                if j is None:
                    continue
                d, ld = g[(j + 2) % 3], int(L[u, (j + 2) % 3])
                new = np.array([[b, c, d], [b, d, a]])
                if (area(new) <= 2 * tol).any():
                    break
                F[t], F[u] = new
                L[t], L[u] = (lb, lc, ld), (lb, ld, la)
                changed = progress = True
                break
        if not progress:
            break
    changed |= unfold_ngon_triangles(arrays, F, L, multi, max_rounds)
    if not changed:
        return arrays
    return MeshArrays(arrays.V, F, L, P, arrays.edges)


def unfold_ngon_triangles(arrays: MeshArrays, F: np.ndarray, L: np.ndarray, multi: np.ndarray,
                          max_rounds: int = 8) -> bool:
    """Flips, in place in ``F`` and ``L`` (the triangles and loops of ``arrays``, or a working copy
    of them), diagonals of n-gon triangles (indices ``multi``) that face against their polygon;
    returns whether any changed. A bent or concave n-gon may be cut into a triangle folded back over
    its neighbour (how depends on the Blender version: 5.x triangulates by vertex positions), and
    curvature estimated across the fold is garbage (a crest line along a rounded edge of hexagons
    broke there). A polygon's normal is its vector area, the sum of its triangles' (the same for
    every triangulation of it). Triangle (x, y, z) and its neighbour (y, x, w) across diagonal x-y
    become (z, x, w) and (w, y, z) when both then face with the polygon. Needs the mesh's edges
    (``arrays.edges``) to tell diagonals from polygon sides: without them nothing changes."""
    E, V, P = arrays.edges, arrays.V, arrays.tri_poly
    if E is None or not len(E) or multi.size == 0:
        return False

    def cross(f):  # (k, 3) index rows
        return np.cross(V[f[:, 1]] - V[f[:, 0]], V[f[:, 2]] - V[f[:, 0]])

    normal = np.zeros((int(P.max()) + 1, 3))
    np.add.at(normal, P[multi], cross(F[multi]))
    bad = multi[np.einsum("ij,ij->i", cross(F[multi]), normal[P[multi]]) <= 0]
    if bad.size == 0:
        return False
    nv = int(len(V))
    real = set(edge_keys(E[:, 0], E[:, 1], nv).tolist())
    suspects = np.flatnonzero(np.isin(P, np.unique(P[bad])))
    members = {}
    for t in suspects.tolist():
        members.setdefault(int(P[t]), []).append(t)

    def flip(t):
        n = normal[P[t]]
        if cross(F[t:t + 1])[0] @ n > 0:  # already unfolded by an earlier flip
            return False
        f = F[t].tolist()
        for k in range(3):
            x, y, z = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
            if edge_key(x, y, nv) in real:
                continue
            for u in members[int(P[t])]:
                g = F[u].tolist()
                j = next((j for j in range(3) if g[j] == y and g[(j + 1) % 3] == x), None)
                if u == t or j is None:
                    continue
                w = g[(j + 2) % 3]
                new = np.array([[z, x, w], [w, y, z]])
                if w != z and (cross(new) @ n > 0).all():
                    lx, ly, lz = (int(L[t, (k + i) % 3]) for i in range(3))
                    lw = int(L[u, (j + 2) % 3])
                    F[t], F[u] = new
                    L[t], L[u] = (lz, lx, lw), (lw, ly, lz)
                    return True
                break
        return False

    changed = False
    for _ in range(max_rounds):
        progress = False
        for t in bad.tolist():
            progress |= flip(t)
        changed |= progress
        bad = suspects[np.einsum("ij,ij->i", cross(F[suspects]), normal[P[suspects]]) <= 0]
        if not progress or bad.size == 0:
            break
    return changed


def orient_region(arrays: MeshArrays, region: np.ndarray) -> MeshArrays:
    """Triangles of a region (``region``: (m,) bool over the triangles, some True) turned to agree
    with their neighbours, outward from the triangles outside it: a region triangle holding a shared
    edge the same way as the neighbour it is reached from is reversed (with its loops). Fill (Alt+F)
    can orient some of its triangles against the mesh, which the flow rejects as 'inconsistent face
    orientation'; the written faces then follow the mesh. Returns new :class:`MeshArrays` (the same
    object when no triangle turns); ``arrays`` is not changed."""
    # Only the region and the faces sharing an edge with it take part (other seeds reach nothing):
    # the walk below over a whole 1M-triangle mesh took 14 s for a 999-face selection.
    n = int(arrays.F.max()) + 1
    key = face_edge_keys(arrays.F, n).ravel()
    region_keys = np.unique(key.reshape(-1, 3)[region])
    pos = np.minimum(np.searchsorted(region_keys, key), len(region_keys) - 1)
    sub = np.flatnonzero((region_keys[pos] == key).reshape(-1, 3).any(1))
    F = arrays.F[sub]
    region = region[sub]
    faces_of = {}
    for f, (a, b, c) in enumerate(F.tolist()):
        for u, v in ((a, b), (b, c), (c, a)):
            faces_of.setdefault(edge_key(u, v, n), []).append(f)

    def has_directed(h, u, v):
        a, b, c = F[h]
        return (u, v) in ((a, b), (b, c), (c, a))

    flip = np.zeros(len(F), bool)
    done = ~region.copy()
    queue = list(np.flatnonzero(done))
    while queue:
        f = queue.pop()
        a, b, c = (F[f][::-1] if flip[f] else F[f]).tolist()
        for u, v in ((a, b), (b, c), (c, a)):
            for h in faces_of[edge_key(u, v, n)]:
                if h != f and not done[h]:
                    flip[h] = has_directed(h, u, v)  # holds the edge the same way as f: turn it
                    done[h] = True
                    queue.append(h)
    if not flip.any():
        return arrays
    flip = sub[flip]
    F2, L2 = arrays.F.copy(), arrays.tri_loops.copy()
    F2[flip] = F2[flip][:, ::-1]
    L2[flip] = L2[flip][:, ::-1]
    return dataclasses.replace(arrays, F=F2, tri_loops=L2)
