"""Data of new elements blended from the elements they are made from (point attributes,
vertex-group weights), and the sources a new point blends over."""

from typing import Callable, List, Optional, Tuple

import numpy as np

from .mesh import ranges

Values = List[Tuple[str, np.ndarray]]  # [(name, (n, k) values)]


def blend_attributes(values: Values, idx, w) -> Values:
    """Values of new elements: new element i gets sum_k w[i, k] * values[idx[i, k]] (integers and
    booleans: the heaviest source's), for each (name, (n, k) values) of ``values``."""
    idx, w = np.asarray(idx), np.asarray(w, dtype=float)
    heavy = idx[np.arange(len(idx)), w.argmax(1)]
    return [(name, a[heavy] if a.dtype.kind in "ib" else np.einsum("nk,nkd->nd", w, a[idx].astype(float)))
            for name, a in values]


def blend_group_weights(idx, w, ev, eg, ew, n_groups: int) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Vertex-group weights blended from sources given as (vertex, group, weight) entries (``ev``,
    ``eg``, ``ew``; groups numbered below ``n_groups``): output vertex i gets sum_k w[i, k] *
    (weights of source idx[i, k]). Returns (vertex, group, weight, counted) per output membership,
    sorted by vertex then group, counted where some source with a nonzero w is a member."""
    idx, w = np.asarray(idx), np.asarray(w, dtype=float)
    o, src, w = np.repeat(np.arange(len(idx)), idx.shape[1]), idx.ravel(), w.ravel()
    order = np.argsort(ev, kind="stable")
    ev, eg, ew = ev[order], eg[order], ew[order]
    start = np.searchsorted(ev, np.arange(int(src.max(initial=-1)) + 2))
    count = start[src + 1] - start[src]
    at = ranges(start[src], count)
    key = np.repeat(o, count) * n_groups + eg[at]
    key, inv = np.unique(key, return_inverse=True)
    weight = np.bincount(inv, np.repeat(w, count) * ew[at])
    counted = np.bincount(inv, np.repeat(w, count)) > 0
    vert, group = np.divmod(key, n_groups)
    return vert, group, weight, counted


def nearest_sources(Q, P, k: int = 16, dense: int = 2_000_000,
                    knn: Optional[Callable[[np.ndarray, np.ndarray, int], np.ndarray]] = None) -> np.ndarray:
    """(len(P), k') indices into the points Q that Shepard's weights for the points P run over: all
    of Q for a hole's rim (len(P) * len(Q) <= ``dense``), else the k nearest: every source for every
    new vertex made a dense matrix, 4 GB for a 10K-triangle object subdivided whole. ``knn(Q, P, k)``
    finds those (a kd-tree: Blender's is ``bridge.kd_nearest``); without it a search over Q in
    chunks of P (exact, slower on large inputs). Each row lists its sources nearest first."""
    if len(P) * len(Q) <= dense:
        return np.broadcast_to(np.arange(len(Q)), (len(P), len(Q)))
    k = min(k, len(Q))
    if knn is not None:
        return knn(Q, P, k)
    out = np.empty((len(P), k), np.int64)
    step = max(1, dense // max(len(Q), 1))
    for s in range(0, len(P), step):
        d2 = ((P[s:s + step, None, :] - Q[None, :, :]) ** 2).sum(-1)
        part = np.argpartition(d2, k - 1, axis=1)[:, :k] if k < len(Q) else np.broadcast_to(np.arange(len(Q)), d2.shape)
        near = np.take_along_axis(d2, part, 1)
        out[s:s + step] = np.take_along_axis(part, np.argsort(near, axis=1, kind="stable"), 1)
    return out
