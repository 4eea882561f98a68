"""Crest lines and their applications (thesis chapter 4).

* :func:`curvature_derivatives`: principal curvatures, directions and extremality coefficients per
  vertex by the enhanced adjacent-normal cubic fit (thesis 4.5, eq. 4.7-4.8).
* :func:`crest_lines`: ridges (convex crest lines) and valleys (concave ones) traced on the mesh
  edges (4.6), with the scale-independent strength T of eq. 4.10 per line for thresholding.
* :func:`decimate`: Garland-Heckbert quadric decimation, optionally feature sensitive (4.8).
* :func:`segment`: variational shape approximation, optionally guided by crest lines (4.9).
"""

from dataclasses import dataclass, field

import numpy as np

from .core import MeshError, _native, as_count, as_faces, as_mask, as_real, as_vertices

RIDGE = 0
VALLEY = 1

_LINE_FIELDS = ("points", "point_edge", "point_t", "point_cyclideness", "segments", "segment_line",
                "segment_face", "line_offset", "line_points", "line_kind", "line_strength", "line_length")


@dataclass(repr=False)
class CrestLines:
    """Crest lines of a mesh.

    Points: ``points`` (P, 3); most lie on a mesh edge ``point_edge`` (P, 2) = (v0, v1) at
    ``(1 - point_t) v0 + point_t v1``; junction points inside a triangle have edge (-1, -1).
    ``point_cyclideness`` is C of eq. 4.11 at the point.
    Segments: ``segments`` (S, 2) point indices, ``segment_line`` the line of each, ``segment_face``
    the triangle holding it (-1 for a gap jump between two line ends, thesis fig. 4.10).
    Lines: ``polylines`` (ordered point arrays; a closed line repeats its first point), ``line_kind``
    (RIDGE = 0 or VALLEY = 1), ``line_strength`` T (eq. 4.10, dimensionless) and ``line_length``.
    ``derivatives`` holds the per-vertex fields (see :func:`curvature_derivatives`).
    ``all_lines`` keeps the unfiltered lines, so :meth:`filter` can lower the threshold again
    without refitting.
    """

    points: np.ndarray
    point_edge: np.ndarray
    point_t: np.ndarray
    point_cyclideness: np.ndarray
    segments: np.ndarray
    segment_line: np.ndarray
    segment_face: np.ndarray
    line_offset: np.ndarray
    line_points: np.ndarray
    line_kind: np.ndarray
    line_strength: np.ndarray
    line_length: np.ndarray
    derivatives: dict = field(default_factory=dict, repr=False)
    threshold: float = 0.0
    all_lines: "CrestLines" = field(default=None, repr=False)

    def __len__(self):
        return len(self.line_kind)

    def __repr__(self):
        ridges = int((self.line_kind == RIDGE).sum())
        return (f"CrestLines({len(self)} lines: {ridges} ridges, {len(self) - ridges} valleys; "
                f"{len(self.points)} points, length {self.total_length:.4g}, threshold {self.threshold:g})")

    @property
    def n_lines(self):
        return len(self.line_kind)

    @property
    def polylines(self):
        """List of (k, 3) point arrays, one per line, in order along the line."""
        o = self.line_offset
        return [self.points[self.line_points[o[i]:o[i + 1]]] for i in range(len(self))]

    @property
    def is_ridge(self):
        return self.line_kind == RIDGE

    @property
    def total_length(self):
        return float(self.line_length.sum())

    def filter(self, threshold=None, ridges=True, valleys=True):
        """Lines with strength T >= threshold of the requested kinds, re-indexed. Filtering always
        starts from every traced line, so a lower threshold brings lines back."""
        base = self.all_lines if self.all_lines is not None else self
        threshold = self.threshold if threshold is None else float(threshold)
        keep = base.line_strength >= threshold
        if not ridges:
            keep &= base.line_kind != RIDGE
        if not valleys:
            keep &= base.line_kind != VALLEY
        return _subset(base, keep, threshold)


def _subset(base, keep, threshold):
    nl = len(base.line_kind)
    new_line = np.full(nl, -1, dtype=np.int32)
    new_line[keep] = np.arange(int(keep.sum()), dtype=np.int32)
    o = base.line_offset
    counts = np.diff(o)
    idx = np.repeat(keep, counts)
    line_points_old = base.line_points[idx]
    used = np.unique(line_points_old)
    new_point = np.full(len(base.points), -1, dtype=np.int32)
    new_point[used] = np.arange(len(used), dtype=np.int32)
    seg_keep = keep[base.segment_line] if len(base.segment_line) else np.zeros(0, bool)
    return CrestLines(
        points=base.points[used],
        point_edge=base.point_edge[used],
        point_t=base.point_t[used],
        point_cyclideness=base.point_cyclideness[used],
        segments=new_point[base.segments[seg_keep]].reshape(-1, 2),
        segment_line=new_line[base.segment_line[seg_keep]],
        segment_face=base.segment_face[seg_keep],
        line_offset=np.concatenate([[0], np.cumsum(counts[keep])]).astype(np.int32),
        line_points=new_point[line_points_old],
        line_kind=base.line_kind[keep],
        line_strength=base.line_strength[keep],
        line_length=base.line_length[keep],
        derivatives=base.derivatives,
        threshold=threshold,
        all_lines=base,
    )


def _check_rings(rings):
    return as_count(rings, "rings", 1, 8)


def curvature_derivatives(V, F, *, rings=1, smooth=True, use_normals=True, fit_tangent_plane=True,
                          transport_to_vertex=True, progress=None):
    """Curvature tensor and its derivatives per vertex (thesis 4.5).

    A cubic (eq. 4.7) is fitted by least squares at each vertex of the smoothed mesh M' (p' = mean of
    the centroids of the faces around p; ``smooth=False`` fits the input) to the positions and Max
    normals of its ``rings``-ring, without neighbours whose normal makes an obtuse angle with the
    vertex normal. Two refinements over eq. 4.7 as printed (both on by default; off reproduces the
    thesis's fit): ``fit_tangent_plane`` adds linear terms and treats the Max normal of p' as one
    more normal equation rather than as exact, and ``transport_to_vertex`` evaluates the fitted
    surface at the foot of the original vertex p instead of at p'. Returns a dict of per-vertex
    arrays: ``k_max``, ``k_min`` (positive on a sphere with outward faces), unit directions
    ``t_max``, ``t_min`` (n, 3), extremality coefficients ``e_max`` = dk_max/dt_max and ``e_min``
    (eq. 4.8-4.9; their sign follows the direction), ``normals`` of the fitted surface.
    """
    return _native.curvature_derivatives(as_vertices(V), as_faces(F), _check_rings(rings), bool(smooth),
                                         bool(use_normals), bool(fit_tangent_plane), bool(transport_to_vertex),
                                         progress)


def crest_lines(V, F, *, rings=1, threshold=0.0, ridges=True, valleys=True, smooth=True, join_gaps=True,
                skip_boundary=True, progress=None):
    """Crest lines of a triangle mesh (thesis 4.5-4.6).

    ``rings`` (1..8, thesis 1..4) is the fitting neighbourhood: larger gives smoother lines and
    ignores smaller features. Lines are zero crossings of the extremality coefficients on the mesh
    edges, with the maximum/minimum and convexity tests, joined across gaps, and kept when their
    strength T (eq. 4.10, scale independent) is at least ``threshold``. Edges touching the mesh
    boundary are skipped when ``skip_boundary`` (the fit is one-sided there).
    Returns :class:`CrestLines`; ``.filter(threshold)`` re-thresholds without refitting.
    """
    d, lines = _native.crest_lines(as_vertices(V), as_faces(F), _check_rings(rings), bool(smooth), True,
                                   True, True, bool(join_gaps), bool(skip_boundary), progress)
    threshold = as_real(threshold, "threshold")
    base = CrestLines(**{k: lines[k] for k in _LINE_FIELDS}, derivatives=d, threshold=0.0)
    return base.filter(threshold, ridges, valleys)


def crest_face_distance(V, F, lines):
    """Geodesic distance from each face to the nearest crest line (thesis 4.8), over the face graph
    with centroid - edge midpoint - centroid steps; 0 on faces holding a line."""
    return _native.crest_face_distance(as_vertices(V), as_faces(F), np.ascontiguousarray(lines.segments, np.int32),
                                       np.ascontiguousarray(lines.segment_face, np.int32),
                                       np.ascontiguousarray(lines.point_edge, np.int32))


def feature_function(distance, eta, eps=0.1):
    """F(d) = (d / max d + eps)^eta of eq. 4.12 (all ones when eta is 0 or there is no line)."""
    d = np.asarray(distance, dtype=np.float64)
    eta = as_real(eta, "feature weight (eta)", 0.0)
    dmax = float(d.max()) if d.size else 0.0
    if eta == 0.0 or dmax <= 0.0:
        return np.ones_like(d)
    return (d / dmax + eps) ** eta


def _check_same_mesh(lines, V, F):
    """MeshError unless ``lines`` were traced on (V, F): every point on an edge must be that edge's
    point at its parameter, and every segment's face must exist."""
    if not isinstance(lines, CrestLines):
        raise MeshError("crest_lines must be a CrestLines result of dgmesh.crest_lines")
    pe = np.asarray(lines.point_edge)
    on_edge = np.flatnonzero(pe[:, 0] >= 0) if len(pe) else np.zeros(0, np.int64)
    ok = (not len(pe) or int(pe.max()) < len(V)) and (not len(lines.segment_face) or
                                                       int(np.max(lines.segment_face)) < len(F))
    if ok and len(on_edge):
        t = np.asarray(lines.point_t)[on_edge, None]
        p = (1 - t) * V[pe[on_edge, 0]] + t * V[pe[on_edge, 1]]
        scale = max(float(np.ptp(V, axis=0).max()), 1e-300)
        ok = float(np.abs(p - np.asarray(lines.points)[on_edge]).max()) <= 1e-9 * scale
    if not ok:
        raise MeshError("crest_lines were computed on another mesh")


def _crest_arrays(V, F, lines):
    """(segments, segment_face, point_edge) of given crest lines for the native feature-guided
    calls, which validate the mesh once and build F(d) on it (no second validation)."""
    if lines is None:
        return None
    _check_same_mesh(lines, V, F)
    return (np.ascontiguousarray(lines.segments, np.int32), np.ascontiguousarray(lines.segment_face, np.int32),
            np.ascontiguousarray(lines.point_edge, np.int32))


def _check_feature_weight(feature_weight):
    return as_real(feature_weight, "feature_weight", 0.0)


def decimate(V, F, *, target_faces, feature_weight=0.0, crest_lines=None, rings=1, threshold=0.0,
             preserve_boundary=True, min_quality=0.0, max_normal_angle=1.3, progress=None, return_map=False,
             return_face_map=False, locked=None, greedy=False, planes=None):
    """Quadric edge-collapse decimation (Garland-Heckbert) to ``target_faces`` faces.

    ``feature_weight`` is eta of thesis eq. 4.12: each face's quadric is weighted by 1 / F(d), d its
    geodesic distance to the nearest crest line, so the mesh stays dense near salient lines;
    0 is plain QEM. Crest lines come from ``crest_lines`` or are detected with ``rings`` and
    ``threshold``. The result is manifold; boundary vertices are kept in place when
    ``preserve_boundary``; ``locked`` (bool per vertex) marks more vertices that must neither move nor
    go (e.g. UV seams). ``planes`` (int per vertex, bit k set: the vertex lies on plane k, e.g. a
    Mirror modifier's) forbids collapses that make a face with its three corners on one plane (it
    would lie in the plane, on its mirror twin). ``min_quality`` in [0, 1) rejects collapses that
    create worse slivers.
    By default collapses run in multiple-choice passes (every edge costed in parallel, the cheapest
    independent ones taken in order); ``greedy=True`` uses one global priority queue instead, the
    exact greedy order of Garland-Heckbert (slower on large meshes, same guards).
    Returns (V, F), plus the input-to-output vertex map when ``return_map``, plus (when
    ``return_face_map``) ``face_map`` (the input triangle each output triangle is, with moved
    corners) and ``source_vertex`` (the input vertex each output vertex is): enough to carry
    per-face and per-corner attributes over.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    target_faces = as_count(target_faces, "target_faces")
    feature_weight = _check_feature_weight(feature_weight)
    crest = _crest_arrays(V, F, crest_lines) if feature_weight else None
    if locked is not None:
        locked = as_mask(locked, len(V), "locked").astype(np.int32)
    if planes is not None:
        planes = np.asarray(planes)
        if planes.shape != (len(V),) or not (planes.dtype == bool or np.issubdtype(planes.dtype, np.integer)):
            raise MeshError(f"planes must be one integer bit mask per vertex ({len(V)},), got {planes.dtype} "
                            f"of shape {planes.shape}")
        planes = planes.astype(np.int32)
    V2, F2, vmap, fmap, src = _native.decimate(V, F, target_faces, None, bool(preserve_boundary),
                                               float(min_quality), float(max_normal_angle),  # checked natively
                                               float("inf"), progress, locked, not bool(greedy), feature_weight,
                                               _check_rings(rings), as_real(threshold, "threshold"), crest,
                                               planes)
    out = (V2, F2) + ((vmap,) if return_map else ()) + ((fmap, src) if return_face_map else ())
    return out


def segment(V, F, *, segments, feature_weight=0.0, crest_lines=None, rings=1, threshold=0.0, iterations=30,
            progress=None, return_info=False):
    """Segments the mesh into ``segments`` connected, nearly planar charts by variational shape
    approximation (L^{2,1} metric, Lloyd iterations; thesis 4.9). ``feature_weight`` is eta of eq.
    4.12: region growing weighs the error of a face reached from a face of a segment by
    2 / (F(T_i) + F(T_j)), so segment borders settle on crest lines. Returns a label per face
    (0 .. n-1; a mesh with more connected components than ``segments`` gets one per component);
    with ``return_info`` also a dict with proxy normals, iterations and the total distortion.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    segments = as_count(segments, "segments", 1)
    feature_weight = _check_feature_weight(feature_weight)
    crest = _crest_arrays(V, F, crest_lines) if feature_weight else None
    out = _native.segment(V, F, segments, None, as_count(iterations, "iterations"), progress, feature_weight,
                          _check_rings(rings), as_real(threshold, "threshold"), crest)
    labels = np.asarray(out["labels"], dtype=np.int32)
    return (labels, dict(out)) if return_info else labels


def snap_to_vertices(lines, V, F):
    """Mesh-vertex pairs approximating each crest segment: every point is moved to the nearer end
    of its edge (a junction point to the nearest corner of its triangle). Returns (S', 2) int32
    pairs of distinct vertices (segments whose ends snap to the same vertex are dropped) and the
    line of each pair. Consecutive pairs share a triangle, except across gap jumps."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    _check_same_mesh(lines, V, F)
    pe = lines.point_edge
    vert = np.where(lines.point_t < 0.5, pe[:, 0], pe[:, 1]).astype(np.int64)
    junction = np.flatnonzero(pe[:, 0] < 0)
    if junction.size:
        # The face of any segment touching the junction point.
        seg_face = np.full(len(pe), -1, dtype=np.int64)
        for k in (0, 1):
            seg_face[lines.segments[:, k]] = np.maximum(seg_face[lines.segments[:, k]], lines.segment_face)
        f = seg_face[junction]
        corners = F[np.maximum(f, 0)]
        d = np.linalg.norm(V[corners] - lines.points[junction][:, None, :], axis=2)
        vert[junction] = corners[np.arange(len(junction)), d.argmin(1)]
    pairs = vert[lines.segments] if len(lines.segments) else np.zeros((0, 2), np.int64)
    keep = pairs[:, 0] != pairs[:, 1]
    return pairs[keep].astype(np.int32), lines.segment_line[keep]


__all__ = ["RIDGE", "VALLEY", "CrestLines", "curvature_derivatives", "crest_lines", "crest_face_distance",
           "feature_function", "decimate", "segment", "snap_to_vertices"]
