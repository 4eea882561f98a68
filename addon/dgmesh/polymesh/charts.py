"""Charts of a polygon mesh cut along seams: the face corners joined across non-seam edges."""

from typing import Optional, Tuple

import numpy as np

from ..core import MeshError
from ..unwrapping import chart_labels


def split_charts(start, total, face_mask, loop_edge, seam, loop_vertex: Optional[np.ndarray] = None
                 ) -> Tuple[np.ndarray, np.ndarray]:
    """Charts of the masked polygons (``start``/``total``: each polygon's first loop and loop count;
    ``face_mask``: bool per polygon; ``loop_edge``: the edge of each loop, from its vertex to the
    next loop's; ``seam``: bool per edge). Polygons sharing a manifold non-seam edge are joined;
    edges of three or more masked polygons are left unjoined. Returns (corner_class,
    chart_of_class): corner_class[l] is the chart vertex of loop l (-1 for loops of unmasked
    polygons), chart_of_class the chart of each chart vertex, both numbered from 0. With
    ``loop_vertex``, two polygons that run a shared edge the same way (one of them flipped) raise
    MeshError: their corners would be joined crosswise."""
    nloop = len(loop_edge)
    poly_of_loop = np.repeat(np.arange(len(start)), total)
    nxt = np.arange(nloop) + 1
    last = start + total - 1
    nxt[last] = start
    in_mask = face_mask[poly_of_loop]
    loops = np.nonzero(in_mask)[0]
    # Loops of masked polygons sharing a non-seam edge: pair them up (two loops per manifold edge).
    e = loop_edge[loops]
    order = np.argsort(e, kind="stable")
    ls, es = loops[order], e[order]
    same = es[1:] == es[:-1]
    # An edge with exactly two masked loops (three or more: non-manifold, left unjoined).
    first = np.nonzero(same)[0]
    ok = np.ones(len(first), bool)
    if len(first):
        before = np.r_[False, same][first]
        after = np.r_[same, False][first + 1]
        ok = ~before & ~after & ~seam[es[first]]
    a, b = ls[first[ok]], ls[first[ok] + 1]
    if loop_vertex is not None:
        same_way = np.flatnonzero(loop_vertex[a] == loop_vertex[b])
        if len(same_way):
            raise MeshError(
                f"inconsistent face orientation (flipped normals) across {len(same_way)} edge(s) (first: edge "
                f"{int(loop_edge[a[same_way[0]]])}); Mesh > Normals > Recalculate Outside, then unwrap")
    # Edge u->v in a's polygon and v->u in b's: a~next(b), next(a)~b.
    vertex_pairs = np.concatenate([np.c_[a, nxt[b]], np.c_[nxt[a], b]]).astype(np.int32)
    cls = chart_labels(nloop, vertex_pairs)
    inner = np.c_[loops, nxt[loops]].astype(np.int32)
    chart_of_loop = chart_labels(nloop, np.concatenate([vertex_pairs, inner]))
    corner_class = np.full(nloop, -1, np.int64)
    used_classes, remap = np.unique(cls[loops], return_inverse=True)
    corner_class[loops] = remap
    chart_of_class = np.empty(len(used_classes), np.int64)
    chart_of_class[remap] = chart_of_loop[loops]
    _, chart_of_class = np.unique(chart_of_class, return_inverse=True)
    return corner_class, chart_of_class
