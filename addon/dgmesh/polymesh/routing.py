"""Shortest paths of mesh edges between vertex pairs (crest lines snapped to vertices are joined
along the mesh's own edges)."""

from typing import Callable, Iterable, List, Optional, Tuple

import numpy as np

from .edges import EdgeLookup, find_edges
from .mesh import ranges


def adjacency(edges, n: int) -> Tuple[np.ndarray, np.ndarray]:
    """CSR adjacency (start (n + 1,), neighbours) of a mesh of n vertices with edges (e, 2): the
    neighbours of v are neighbours[start[v]:start[v + 1]], in the order of the edges (each edge's
    first direction, then the reversed ones)."""
    edges = np.asarray(edges).reshape(-1, 2)
    both = np.concatenate([edges, edges[:, ::-1]])
    order = np.argsort(both[:, 0], kind="stable")
    nbr = both[order, 1]
    start = np.searchsorted(both[order, 0], np.arange(n + 1))
    return start, nbr


def route(a: int, b: int, neighbours: Callable[[int], Iterable[int]], max_depth: int = 4) -> Optional[List[int]]:
    """Shortest path of edges from vertex a to vertex b, at most ``max_depth`` edges long (breadth
    first, neighbours in the order ``neighbours(v)`` gives them): the list of vertices a .. b, or
    None when b is farther."""
    prev = {a: None}
    frontier = [a]
    for _ in range(max_depth):
        nxt = []
        for v in frontier:
            for w in neighbours(v):
                if w in prev:
                    continue
                prev[w] = v
                if w == b:
                    path = [b]
                    while prev[path[-1]] is not None:
                        path.append(prev[path[-1]])
                    return path[::-1]
                nxt.append(w)
        frontier = nxt
    return None


def route_edges(pairs, edges, lookup: EdgeLookup) -> Tuple[np.ndarray, np.ndarray]:
    """Edges along the shortest path of edges (:func:`route`, neighbours in :func:`adjacency`
    order) between each vertex pair (k, 2) that is not an edge itself: (edge indices, index of the
    pair each edge belongs to); pairs farther than 4 edges apart get none. ``lookup`` is
    ``edge_lookup(edges, n)``.

    Most such pairs are the triangulation diagonal of a quad or n-gon, two steps apart. Their path
    a -> c -> b goes through the first neighbour c of a, in adjacency order, that is joined to b
    (the one the breadth-first search meets first): found for all pairs at once. Only the others
    (gap jumps, wider n-gons) are searched one by one (searching all 16K diagonals of a 1M-triangle
    quad grid so took 0.34 s).
    """
    pairs = np.asarray(pairs).reshape(-1, 2)
    start, nbr = adjacency(edges, lookup.n)
    a, b = pairs[:, 0], pairs[:, 1]
    # Every neighbour c of each a, grouped by pair in adjacency order; the first one joined to b.
    count = start[a + 1] - start[a]
    pair = np.repeat(np.arange(len(pairs)), count)
    c = nbr[ranges(start[a], count)]
    cb = find_edges(lookup, np.column_stack([c, b[pair]]))
    hit = np.flatnonzero(cb >= 0)
    two, first = np.unique(pair[hit], return_index=True)
    via = hit[first]
    ac = find_edges(lookup, np.column_stack([a[two], c[via]]))
    found, owner = [ac, cb[via]], [two, two]

    def neighbours(v):
        return nbr[start[v]:start[v + 1]].tolist()

    for i in np.setdiff1d(np.arange(len(pairs)), two).tolist():
        path = route(int(a[i]), int(b[i]), neighbours)
        if path is not None:
            found.append(find_edges(lookup, np.column_stack([path[:-1], path[1:]])))
            owner.append(np.full(len(path) - 1, i))
    return np.concatenate(found), np.concatenate(owner)
