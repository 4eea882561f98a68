"""Undirected edges as integer keys: the one definition every edge lookup of the add-on uses.

The key of edge {a, b} in a mesh of n vertices (n greater than every index) is
min(a, b) * n + max(a, b): the same for both directions, unique per edge, and ordered as the
sorted pairs (min, max) are, so sorting keys sorts edges lexicographically.
"""

from dataclasses import dataclass

import numpy as np


def edge_key(a: int, b: int, n: int) -> int:
    """The key of one edge {a, b} (Python ints: a numpy int32 would overflow) for per-pair queries
    in loops, e.g. against ``set(edge_keys(...).tolist())``; the same value as :func:`edge_keys`."""
    return a * n + b if a < b else b * n + a


def edge_keys(a, b, n) -> np.ndarray:
    """int64 keys of the undirected edges {a[i], b[i]} (arrays of vertex indices)."""
    a = np.asarray(a)
    b = np.asarray(b)
    return np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)


def face_edge_keys(F, n) -> np.ndarray:
    """(m, 3) keys of the sides of triangles F (m, 3): side k joins corners k and k + 1."""
    F = np.asarray(F)
    return edge_keys(F, F[:, [1, 2, 0]], n)


def half_edge_keys(a, b, n) -> np.ndarray:
    """int64 keys a * n + b of the directed half-edges a -> b (one per direction)."""
    return np.asarray(a).astype(np.int64) * n + np.asarray(b)


@dataclass(frozen=True)
class EdgeLookup:
    """A mesh's edges sorted by key, to find the index of vertex pairs in bulk (:func:`find_edges`)."""

    keys: np.ndarray  # (e,) sorted edge keys
    order: np.ndarray  # (e,) index (row of the edge array) of each sorted key
    n: int  # vertex count the keys are made with


def edge_lookup(edges, n: int) -> EdgeLookup:
    """The lookup of edges (e, 2) of a mesh of n vertices."""
    edges = np.asarray(edges).reshape(-1, 2)
    keys = edge_keys(edges[:, 0], edges[:, 1], n)
    order = np.argsort(keys)
    return EdgeLookup(keys[order], order, int(n))


def find_edges(lookup: EdgeLookup, pairs) -> np.ndarray:
    """Index of the edge joining each vertex pair (k, 2) (either direction), -1 where the pair is no
    edge."""
    pairs = np.asarray(pairs).reshape(-1, 2)
    skeys, order = lookup.keys, lookup.order
    q = edge_keys(pairs[:, 0], pairs[:, 1], lookup.n)
    pos = np.clip(np.searchsorted(skeys, q), 0, max(len(skeys) - 1, 0))
    found = len(skeys) > 0
    hit = (skeys[pos] == q) if found else np.zeros(len(q), bool)
    return np.where(hit, order[pos] if found else -1, -1)
