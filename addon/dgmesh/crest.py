"""Crest lines and their applications (thesis chapter 4).

* :func:`curvature_derivatives`: principal curvatures, directions and extremality coefficients per
  vertex by the enhanced adjacent-normal cubic fit (thesis 4.5, eq. 4.7-4.8).
* :func:`crest_lines`: ridges (convex crest lines) and valleys (concave ones) traced on the mesh
  edges (4.6), with the scale-independent strength T of eq. 4.10 per line for thresholding.
* :func:`decimate`: Garland-Heckbert quadric decimation, optionally feature sensitive (4.8).
* :func:`segment`: variational shape approximation, optionally guided by crest lines (4.9).
"""

import numpy as np
import numpy.typing as npt

from .core import MeshError, Progress, _native, as_count, as_faces, as_flag, as_mask, as_real, as_vertices, make_options

# The contract is the C++ one (dgmesh/crest_lines.h, decimate.h, segment.h), bound as it is: the
# options with their defaults, the results, the line kinds, and the feature-guidance presets of
# decimation and segmentation.
DerivativeOptions = _native.DerivativeOptions
CurvatureDerivatives = _native.CurvatureDerivatives
CrestOptions = _native.CrestOptions
CrestKind = _native.CrestKind
FeatureOptions = _native.FeatureOptions
DecimateOptions = _native.DecimateOptions
DecimateResult = _native.DecimateResult
SegmentOptions = _native.SegmentOptions
SegmentResult = _native.SegmentResult

RIDGE = int(CrestKind.ridge)
VALLEY = int(CrestKind.valley)
MAX_FEATURE_WEIGHT: float = _native.MAX_FEATURE_WEIGHT  # the largest feature_weight (eta) accepted
# noise_adaptive: above this median quartic / cubic residual ratio the jet fit gives way to the thesis fit
JET_NOISE_RATIO: float = _native.JET_NOISE_RATIO



def decimate_feature_defaults() -> FeatureOptions:
    """Feature guidance of :func:`decimate`: eta 6 (thesis fig. 4.19), lines with T >= 10."""
    return _native.decimate_feature_defaults()


def segment_feature_defaults() -> FeatureOptions:
    """Feature guidance of :func:`segment`: eta 2 (thesis fig. 4.26-4.27), lines with T >= 10."""
    return _native.segment_feature_defaults()


_FIT = DerivativeOptions()
_CREST = CrestOptions()
_DECIMATE = DecimateOptions()
_DECIMATE_FEATURES = decimate_feature_defaults()
_SEGMENT = SegmentOptions()
_SEGMENT_FEATURES = segment_feature_defaults()


class CrestLines:
    """Crest lines of a mesh at one threshold: the bound C++ result ``_native.CrestLines``
    (``lines``) with the fit it came from.

    A thin wrapper, because re-thresholding needs what the C++ struct does not hold: every traced
    line (``all_lines``, a ``_native.CrestLines``), so that :meth:`filter` can lower the threshold
    again without refitting, and the per-vertex fields (``derivatives``, a
    :class:`CurvatureDerivatives`, see :func:`curvature_derivatives`). Filtering itself is the
    C++ ``filter_crest_lines``.

    The fields of ``lines`` read as attributes (numpy views): points ``points`` (P, 3); most lie on
    a mesh edge ``point_edge`` (P, 2) = (v0, v1) at ``(1 - point_t) v0 + point_t v1``; junction
    points inside a triangle have edge (-1, -1). ``point_cyclideness`` is C of eq. 4.11 at the
    point. Segments: ``segments`` (S, 2) point indices, ``segment_line`` the line of each,
    ``segment_face`` the triangle holding it (-1 for a gap jump between two line ends, thesis
    fig. 4.10). Lines: ``line_offset`` / ``line_points`` (CSR point lists), ``polylines`` (ordered
    point arrays; a closed line repeats its first point), ``line_kind`` (RIDGE = 0 or VALLEY = 1),
    ``line_strength`` T (eq. 4.10, dimensionless) and ``line_length``.
    """

    __slots__ = ("lines", "derivatives", "threshold", "all_lines")

    def __init__(self, lines: _native.CrestLines, derivatives: CurvatureDerivatives, threshold: float = 0.0,
                 all_lines: _native.CrestLines | None = None) -> None:
        self.lines = lines
        self.derivatives = derivatives
        self.threshold = threshold
        self.all_lines = lines if all_lines is None else all_lines

    def __len__(self) -> int:
        return len(self.line_kind)

    def __repr__(self) -> str:
        ridges = int((self.line_kind == RIDGE).sum())
        return (f"CrestLines({len(self)} lines: {ridges} ridges, {len(self) - ridges} valleys; "
                f"{len(self.points)} points, length {self.total_length:.4g}, threshold {self.threshold:g})")

    @property
    def n_lines(self) -> int:
        return len(self.line_kind)

    @property
    def polylines(self) -> list[np.ndarray]:
        """List of (k, 3) point arrays, one per line, in order along the line."""
        o = self.line_offset
        return [self.points[self.line_points[o[i]:o[i + 1]]] for i in range(len(self))]

    @property
    def is_ridge(self) -> np.ndarray:
        return self.line_kind == RIDGE

    @property
    def total_length(self) -> float:
        return float(self.line_length.sum())

    def filter(self, threshold: float | None = None, ridges: bool = True, valleys: bool = True) -> "CrestLines":
        """Lines with strength T >= threshold of the requested kinds, re-indexed. Filtering always
        starts from every traced line, so a lower threshold brings lines back."""
        threshold = self.threshold if threshold is None else as_real(threshold, "threshold")
        lines = _native.filter_crest_lines(self.all_lines, threshold, as_flag(ridges, "ridges"),
                                             as_flag(valleys, "valleys"))
        return CrestLines(lines, self.derivatives, threshold, self.all_lines)


def _line_field(name):
    return property(lambda self: getattr(self.lines, name), doc=getattr(_native.CrestLines, name).__doc__)


for _name in _native.CrestLines.__fields__:
    setattr(CrestLines, _name, _line_field(_name))
del _name


def _check_rings(rings):
    return as_count(rings, "rings", 1, 8)


def curvature_derivatives(V: npt.ArrayLike, F: npt.ArrayLike, *, rings: int = _FIT.rings, jet: bool = _FIT.jet,
                          noise_adaptive: bool = _FIT.noise_adaptive, smooth: bool = _FIT.smooth, use_normals: bool = _FIT.use_normals,
                          fit_tangent_plane: bool = _FIT.fit_tangent_plane,
                          transport_to_vertex: bool = _FIT.transport_to_vertex,
                          progress: Progress | None = None) -> CurvatureDerivatives:
    """Curvature tensor and its derivatives per vertex (thesis 4.5).

    ``jet=True`` (default): a two-pass fit at each vertex p of the input, several times more accurate than
    the thesis's fit on smooth meshes and more accurate than CGAL's jet fitting (bench
    ``crest_derivatives``), but more sensitive to noise. Pass 1 estimates the normal of every
    vertex from a jet fitted to the heights of its 2-ring (quartic for one-ring fits, cubic
    otherwise); pass 2 fits a jet (free tangent plane, degree 3 on the one-ring, 5 on larger rings;
    a one-ring of fewer than six vertices is widened to the 2-ring) to the heights of the
    ``rings``-ring and the slopes of their pass-1 normals. ``smooth``, ``use_normals``,
    ``fit_tangent_plane`` and ``transport_to_vertex`` then do not apply, unless ``noise_adaptive``
    (default on) finds the mesh noisy: the median ratio of the residuals of quartic and cubic fits
    to 2-ring heights exceeds ``JET_NOISE_RATIO`` (truncation error falls with the degree, noise
    does not), and the thesis fit below is used instead. The result's ``noise_ratio`` and
    ``jet_used`` say what happened; ``e_max_error`` / ``e_min_error`` are the jet's standard errors
    of e.

    ``jet=False``: the thesis's fit. A cubic (eq. 4.7) is fitted by least squares at each vertex
    of the smoothed mesh M' (p' = mean of the centroids of the faces around p; ``smooth=False`` fits the input) to the positions and Max
    normals of its ``rings``-ring, without neighbours whose normal makes an obtuse angle with the
    vertex normal. Two refinements over eq. 4.7 as printed (both on by default; off reproduces the
    thesis's fit): ``fit_tangent_plane`` adds linear terms and treats the Max normal of p' as one
    more normal equation rather than as exact, and ``transport_to_vertex`` evaluates the fitted
    surface at the foot of the original vertex p instead of at p' (thesis fit only).
    Defaults: ``DerivativeOptions()``.
    Returns a :class:`CurvatureDerivatives` of per-vertex arrays: ``k_max``, ``k_min`` (positive on
    a sphere with outward faces), unit directions ``t_max``, ``t_min`` (n, 3), extremality
    coefficients ``e_max`` = dk_max/dt_max and ``e_min`` (eq. 4.8-4.9; their sign follows the
    direction), ``normals`` of the fitted surface.
    """
    fit = make_options(DerivativeOptions(), rings=_check_rings(rings), jet=jet, noise_adaptive=noise_adaptive,
                       smooth=smooth, use_normals=use_normals, fit_tangent_plane=fit_tangent_plane,
                       transport_to_vertex=transport_to_vertex)
    return _native.curvature_derivatives(as_vertices(V), as_faces(F), fit, progress)


def crest_lines(V: npt.ArrayLike, F: npt.ArrayLike, *, rings: int = _FIT.rings, threshold: float = _CREST.threshold,
                ridges: bool = _CREST.ridges, valleys: bool = _CREST.valleys, jet: bool = _FIT.jet,
                noise_adaptive: bool = _FIT.noise_adaptive, plateaus: bool = _FIT.plateaus, smooth: bool = _FIT.smooth,
                join_gaps: bool = _CREST.join_gaps, skip_boundary: bool = _CREST.skip_boundary,
                progress: Progress | None = None) -> CrestLines:
    """Crest lines of a triangle mesh (thesis 4.5-4.6).

    ``rings`` (1..8, thesis 1..4) is the fitting neighbourhood: larger gives smoother lines and
    ignores smaller features. Lines are zero crossings of the extremality coefficients on the mesh
    edges, with the maximum/minimum and convexity tests, joined across gaps, and kept when their
    strength T (eq. 4.10, scale independent) is at least ``threshold`` (default 10: the salient
    lines of typical scans; 0 keeps every line). Edges touching the mesh boundary are skipped when
    ``skip_boundary`` (the fit is one-sided there). Defaults: ``DerivativeOptions()`` and
    ``CrestOptions()``. ``jet``, ``noise_adaptive`` and ``smooth`` are those of
    :func:`curvature_derivatives`. With the jet fit and ``plateaus`` (default on) the lines are
    traced on the thesis fit where the dominant curvature is constant along its line of curvature
    to within the jet's own error, and within the jet's support of such places (flat regions, G1
    blends of constant radius): there the jet's e is 0 up to round-off, while the thesis fit's
    smoothing puts a blend's crest line on its middle.
    Returns :class:`CrestLines`; ``.filter(threshold)`` re-thresholds without refitting.
    """
    fit = make_options(DerivativeOptions(), rings=_check_rings(rings), jet=jet, noise_adaptive=noise_adaptive,
                       plateaus=plateaus, smooth=smooth)
    # Every line is traced (threshold 0, both kinds) and kept, so that filter() can bring lines back.
    trace = make_options(CrestOptions(), ridges=True, valleys=True, threshold=0.0, join_gaps=join_gaps,
                         skip_boundary=skip_boundary)
    threshold = as_real(threshold, "threshold")
    ridges, valleys = as_flag(ridges, "ridges"), as_flag(valleys, "valleys")
    d, lines = _native.crest_lines(as_vertices(V), as_faces(F), fit, trace, progress)
    return CrestLines(lines, d).filter(threshold, ridges, valleys)


def crest_face_distance(V: npt.ArrayLike, F: npt.ArrayLike, lines: CrestLines) -> np.ndarray:
    """Geodesic distance from each face to the nearest crest line (thesis 4.8), over the face graph
    with centroid - edge midpoint - centroid steps; 0 on faces holding a line."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    return _native.crest_face_distance(V, F, _native_lines(lines))


def feature_function(distance: npt.ArrayLike, eta: float, eps: float = 0.1) -> np.ndarray:
    """F(d) = (d / max d + eps)^eta of eq. 4.12 (all ones when eta is 0 or there is no line)."""
    d = np.asarray(distance, dtype=np.float64)
    eta = as_real(eta, "feature weight (eta)", 0.0)
    dmax = float(d.max()) if d.size else 0.0
    if eta == 0.0 or dmax <= 0.0:
        return np.ones_like(d)
    return (d / dmax + eps) ** eta


def _native_lines(lines):
    if not isinstance(lines, CrestLines):
        raise MeshError("crest_lines must be a CrestLines result of dgmesh.crest_lines")
    return lines.lines


def _check_same_mesh(lines, V, F):
    """MeshError unless ``lines`` were traced on (V, F): every point on an edge must be that edge's
    point at its parameter, and every segment's face must exist."""
    _native_lines(lines)
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


def _features(V, F, feature_weight, crest_lines, rings, threshold, defaults):
    """The FeatureOptions (from the preset function ``defaults``) of a feature-guided call and the
    native lines to use (None: detected natively with ``rings`` and ``threshold``, on the mesh
    validated once there)."""
    features = make_options(defaults(), feature_weight=feature_weight,  # its range: checked natively
                            rings=_check_rings(rings), threshold=as_real(threshold, "threshold"))
    lines = None
    if features.feature_weight and crest_lines is not None:
        _check_same_mesh(crest_lines, V, F)
        lines = crest_lines.lines
    return features, lines


def decimate(V: npt.ArrayLike, F: npt.ArrayLike, *, target_faces: int,
             feature_weight: float = _DECIMATE_FEATURES.feature_weight, crest_lines: CrestLines | None = None,
             rings: int = _DECIMATE_FEATURES.rings, threshold: float = _DECIMATE_FEATURES.threshold,
             preserve_boundary: bool = _DECIMATE.preserve_boundary, min_quality: float = _DECIMATE.min_quality,
             max_normal_angle: float = _DECIMATE.max_normal_angle, progress: Progress | None = None,
             return_map: bool = False, return_face_map: bool = False, locked: npt.ArrayLike | None = None,
             greedy: bool = not _DECIMATE.batched, planes: npt.ArrayLike | None = None) -> tuple[np.ndarray, ...]:
    """Quadric edge-collapse decimation (Garland-Heckbert) to ``target_faces`` faces.

    ``feature_weight`` is eta of thesis eq. 4.12: each face's quadric is weighted by 1 / F(d), d its
    geodesic distance to the nearest crest line, so the mesh stays dense near salient lines;
    0 is plain QEM. Crest lines come from ``crest_lines`` or are detected with ``rings`` and
    ``threshold``. Defaults: ``decimate_feature_defaults()`` (eta 6, the thesis's fig. 4.19; T >= 10)
    and ``DecimateOptions()``. The result is manifold; boundary vertices are kept in place when
    ``preserve_boundary``; ``locked`` (bool per vertex) marks more vertices that must neither move nor
    go (e.g. UV seams). ``planes`` (int per vertex, bit k set: the vertex lies on plane k, e.g. a
    Mirror modifier's) forbids collapses that make a face with its three corners on one plane (it
    would lie in the plane, on its mirror twin). ``min_quality`` in [0, 1) rejects collapses that
    leave the worst triangle around them below it and worse than before (a fan of slivers, e.g. at
    a pole, may still collapse).
    By default collapses run in multiple-choice passes (every edge costed in parallel, the cheapest
    independent ones taken in order); ``greedy=True`` uses one global priority queue instead, the
    exact greedy order of Garland-Heckbert (slower on large meshes, same guards).
    Returns (V, F), plus the input-to-output vertex map when ``return_map``, plus (when
    ``return_face_map``) ``face_map`` (the input triangle each output triangle is, with moved
    corners) and ``source_vertex`` (the input vertex each output vertex is): enough to carry
    per-face and per-corner attributes over. The arrays are views of one :class:`DecimateResult`.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    options = make_options(DecimateOptions(), target_faces=as_count(target_faces, "target_faces"),
                           preserve_boundary=preserve_boundary, min_quality=min_quality,
                           max_normal_angle=max_normal_angle, batched=not as_flag(greedy, "greedy"))  # ranges: native
    return_map, return_face_map = as_flag(return_map, "return_map"), as_flag(return_face_map, "return_face_map")
    features, lines = _features(V, F, feature_weight, crest_lines, rings, threshold,
                                decimate_feature_defaults)
    if locked is not None:
        locked = as_mask(locked, len(V), "locked").astype(np.int32)
    if planes is not None:
        planes = np.asarray(planes)
        if planes.shape != (len(V),) or not (planes.dtype == bool or np.issubdtype(planes.dtype, np.integer)):
            raise MeshError(f"planes must be one integer bit mask per vertex ({len(V)},), got {planes.dtype} "
                            f"of shape {planes.shape}")
        planes = planes.astype(np.int32)
    r = _native.decimate(V, F, options, features, lines, locked, planes, progress)
    out = (r.V, r.F) + ((r.vertex_map,) if return_map else ())
    return out + ((r.face_map, r.source_vertex) if return_face_map else ())


def segment(V: npt.ArrayLike, F: npt.ArrayLike, *, segments: int = _SEGMENT.segments,
            feature_weight: float = _SEGMENT_FEATURES.feature_weight, crest_lines: CrestLines | None = None,
            rings: int = _SEGMENT_FEATURES.rings, threshold: float = _SEGMENT_FEATURES.threshold,
            iterations: int = _SEGMENT.iterations, progress: Progress | None = None,
            return_info: bool = False) -> np.ndarray | tuple[np.ndarray, SegmentResult]:
    """Segments the mesh into ``segments`` connected, nearly planar charts by variational shape
    approximation (L^{2,1} metric, Lloyd iterations; thesis 4.9). ``feature_weight`` is eta of eq.
    4.12: region growing weighs the error of a face reached from a face of a segment by
    2 / (F(T_i) + F(T_j)), so segment borders settle on crest lines (given as ``crest_lines`` or
    detected with ``rings`` and ``threshold``). Defaults: ``SegmentOptions()`` (25 segments, the
    thesis's figures) and ``segment_feature_defaults()`` (eta 2; T >= 10). Returns a label per face
    (0 .. n-1; a mesh with more connected components than ``segments`` gets one per component);
    with ``return_info`` also the :class:`SegmentResult` (labels, proxy normals, n_segments,
    iterations and the total distortion).
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    options = make_options(SegmentOptions(), segments=as_count(segments, "segments", 1),
                           iterations=as_count(iterations, "iterations"))
    return_info = as_flag(return_info, "return_info")
    features, lines = _features(V, F, feature_weight, crest_lines, rings, threshold,
                                segment_feature_defaults)
    r = _native.segment(V, F, options, features, lines, progress)
    return (r.labels, r) if return_info else r.labels


def snap_to_vertices(lines: CrestLines, V: npt.ArrayLike, F: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
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


__all__ = ["JET_NOISE_RATIO", "MAX_FEATURE_WEIGHT", "RIDGE", "VALLEY", "CrestKind", "CrestLines", "CrestOptions", "CurvatureDerivatives", "DecimateOptions",
           "DecimateResult", "DerivativeOptions", "FeatureOptions", "SegmentOptions", "SegmentResult",
           "curvature_derivatives", "crest_lines", "crest_face_distance", "decimate_feature_defaults",
           "feature_function", "decimate", "segment", "segment_feature_defaults", "snap_to_vertices"]
