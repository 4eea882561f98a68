"""Low-stretch UV unwrapping by stretch equalization (thesis chapter 5) and UV distortion metrics.

``unwrap`` maps one chart -- a connected triangle mesh of disk topology, possibly with holes -- to
the plane (``unwrap_charts`` every chart of a mesh, in one call); the options, their defaults and
the results are the C++ ones (dgmesh/unwrap.h), bound as they are:

* U0: the longest boundary loop is fixed on a convex polygon (arc-length spaced; the free boundary
  is the least-squares conformal map's) and every other vertex is a convex combination of its
  neighbours (eq. 5.2-5.3). With a convex polygon the map has no flipped triangles (Tutte, Floater).
* Stretch equalization: each step divides the weights by the vertex stretch (eq. 5.1, 5.4) raised
  to ``eta`` (eq. 5.6) and solves again. ``iterations="optimal"`` stops when the L2 stretch of
  eq. 5.5 stops decreasing (Uopt); an integer runs exactly that many steps (1 gives U1).
* Holes (inner boundary loops) are filled by a virtual fan for the solves, so they stay open.
* Square corners are placed so that no triangle has all three corners on one side of the square
  (which would give it zero UV area).

The defaults (``UnwrapOptions()``: free boundary, auto weights, eta 0.5, sliding boundary, Uopt)
give the lowest stretch measured on the CGAL disk scans (bench unwrap_quality); the thesis's own
setting (unit square, Floater's weights, eta 1, fixed boundary) is ``thesis_defaults()``.

Metrics (thesis 5.3, ``UvMetrics``), per step and from ``uv_metrics``: ``stretch_l2`` (eq. 5.5, Sander's
normalisation: 1 is an isometry up to scale; infinite when a UV triangle has zero area),
``stretch_linf``, ``stretch_l2_finite`` (eq. 5.5 over the non-degenerate triangles), ``edge``,
``angle`` (mean absolute angle error, radians), ``area``, ``flipped`` and ``zero_area`` counts.
"""

import numpy as np
import numpy.typing as npt

from .core import MeshError, Progress, _native, as_count, as_faces, as_flag, as_real, as_vertices, make_options

__all__ = ["AutoUnwrapOptions", "AutoUnwrapResult", "auto_unwrap", "UnwrapOptions", "UnwrapResult", "UnwrapStep",
           "UnwrapChartsResult", "UnwrapChartError", "UvMetrics", "UvBoundary", "UvWeights", "UvSolver", "thesis_defaults",
           "unwrap", "unwrap_charts", "uv_metrics", "uv_stretch"]

# The contract is the C++ one (dgmesh/unwrap.h), bound as it is.
UnwrapOptions = _native.UnwrapOptions
UnwrapResult = _native.UnwrapResult
UnwrapStep = _native.UnwrapStep
UnwrapChartsResult = _native.UnwrapChartsResult
UnwrapChartError = _native.UnwrapChartError
UvMetrics = _native.UvMetrics
UvBoundary = _native.UvBoundary
UvWeights = _native.UvWeights
UvSolver = _native.UvSolver
AutoUnwrapOptions = _native.AutoUnwrapOptions
AutoUnwrapResult = _native.AutoUnwrapResult
_D = UnwrapOptions()
_A = AutoUnwrapOptions()


def thesis_defaults() -> UnwrapOptions:
    """The thesis's setting (chapter 5): unit square, Floater's weights, eta 1, the boundary fixed,
    no final stretch minimisation.
    For :func:`unwrap`: ``t = thesis_defaults(); unwrap(V, F, boundary=t.boundary, weights=t.weights,
    eta=t.eta, slide_boundary=t.slide_boundary, stretch_iterations=t.stretch_iterations)``."""
    return _native.unwrap_thesis_defaults()


def _options(boundary, weights, eta, iterations, slide_boundary, max_iterations, min_improvement, solver,
             stretch_iterations):
    """UnwrapOptions from the keywords of unwrap() ("optimal" is iterations -1)."""
    if isinstance(iterations, str) and iterations == "optimal":
        iterations = -1
    elif iterations != -1:
        try:
            iterations = as_count(iterations, "iterations")
        except MeshError:
            raise MeshError(f"iterations must be 'optimal' (or -1) or an integer >= 0, got {iterations!r}") from None
    return make_options(UnwrapOptions(), boundary=boundary, weights=weights, eta=eta, iterations=iterations,
                        slide_boundary=slide_boundary,
                        max_iterations=None if max_iterations is None else as_count(max_iterations, "max_iterations"),
                        min_improvement=min_improvement, solver=solver,
                        stretch_iterations=None if stretch_iterations is None
                        else as_count(stretch_iterations, "stretch_iterations"))


def unwrap(V: npt.ArrayLike, F: npt.ArrayLike, *, boundary: str | UvBoundary = _D.boundary.name,
           weights: str | UvWeights = _D.weights.name, eta: float = _D.eta, iterations: int | str = _D.iterations,
           slide_boundary: bool = _D.slide_boundary, max_iterations: int = _D.max_iterations,
           min_improvement: float = _D.min_improvement, solver: str | UvSolver = _D.solver.name,
           stretch_iterations: int = _D.stretch_iterations, progress: Progress | None = None) -> UnwrapResult:
    """Low-stretch parameterization of one disk-like chart (thesis chapter 5).

    V: (n, 3) vertex positions, F: (m, 3) triangles (one connected piece of genus 0 with at least
    one boundary loop; every vertex used). The keywords are the fields of :class:`UnwrapOptions`
    (their defaults its defaults):

    boundary: "square" (the thesis), "circle", or "free" (the natural boundary of the
        least-squares conformal map; falls back to a circle, with a warning, if that boundary folds
        the map).
    weights: "floater" (shape-preserving, the thesis's), "mean_value", "cotangent" (may fold:
        warns), "uniform", or "auto" (beyond the thesis: cotangent, and Floater's from the start
        again as soon as a cotangent map folds or its solve stalls; mean-value weights on a chart
        with holes).
    eta: strength of each equalization step, 0 < eta <= 1 (eq. 5.6).
    iterations: "optimal" or -1 for Uopt, or an int k >= 0 for exactly k steps (0 = U0, 1 = U1).
    slide_boundary: beyond the thesis (whose boundary stays fixed): each step also slides the
        outer boundary vertices along the polygon by a one-dimensional stretch equalization (the
        square's corners stay). The polygon keeps its shape, so no triangle can flip.
    max_iterations: cap on Uopt's steps. min_improvement: Uopt also stops after a step that
        lowers the L2 stretch by less than this fraction.
    solver: "auto" (UMFPACK up to 1000 vertices, multigrid above), "umfpack", "sparselu",
        "bicgstab" (warm-started BiCGSTAB + ILUT) or "multigrid" (warm-started BiCGSTAB with a
        smoothed-aggregation multigrid preconditioner).
    stretch_iterations: beyond the thesis: at most this many Newton steps of a final direct
        minimisation of the L2 stretch (eq. 5.5) with an injectivity barrier, from the map above
        (free boundary); kept only if it lowers the L2 stretch with no flipped or zero-area
        triangle, as the last entry of ``steps`` (``stretch_step`` its index). 0 turns it off.
    progress: optional callable(fraction) -> bool; returning False raises :class:`Cancelled`.

    Returns :class:`UnwrapResult`: ``uv`` (n, 2) the returned map in [0, 1]^2, ``uv_initial`` U0,
    ``steps`` (``steps[h]`` is U^h: ``metrics`` (:class:`UvMetrics`), ``seconds``,
    ``solver_iterations``; every step carries every metric; for Uopt the last may be the rejected
    step; the stretch minimisation's map, when kept, is the last), ``chosen`` (index of
    the returned map; ``final`` and ``initial`` are its and U0's metrics), ``boundary_used``,
    ``boundary_convex`` (then no triangle can flip), ``n_holes`` (inner loops, kept open),
    ``corners`` (vertices at the square's corners (0,0), (1,0), (1,1), (0,1)), ``warnings``
    (fallbacks, negative weights) and ``solver``.

    Raises MeshError for meshes that are not one disk-like chart (closed, several pieces,
    handles), with a message saying what to do, and for options out of range.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    o = _options(boundary, weights, eta, iterations, slide_boundary, max_iterations, min_improvement, solver,
                 stretch_iterations)
    return _native.unwrap(V, F, o, progress)


def unwrap_charts(V: npt.ArrayLike, F: npt.ArrayLike, charts: npt.ArrayLike, *,
                  boundary: str | UvBoundary = _D.boundary.name, weights: str | UvWeights = _D.weights.name,
                  eta: float = _D.eta, iterations: int | str = _D.iterations, slide_boundary: bool = _D.slide_boundary,
                  max_iterations: int = _D.max_iterations, min_improvement: float = _D.min_improvement,
                  solver: str | UvSolver = _D.solver.name, stretch_iterations: int = _D.stretch_iterations,
                  progress: Progress | None = None) -> UnwrapChartsResult:
    """Every chart of a mesh in one call: ``charts`` (m,) labels the triangles 0 .. k-1 (every
    label used), and chart c (the triangles labelled c) is unwrapped as :func:`unwrap` unwraps it
    alone (its vertices in increasing order of their index in V, its triangles in the order of F).
    Charts may share vertices (segments of one mesh): the UVs are per triangle corner. Options as
    :func:`unwrap`; progress runs over the charts in proportion to their triangles.

    Returns :class:`UnwrapChartsResult`: ``uv`` (3m, 2), row 3f + k the UV of corner k of triangle
    f in its chart's map (``uv.reshape(-1, 3, 2)``: per triangle), and ``charts``, chart c's
    :class:`UnwrapResult`.

    Raises :class:`UnwrapChartError` (a MeshError with ``chart``, from 0, and ``reason``) for the
    first chart that is not disk-like; nothing is returned then.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    labels = np.asarray(charts)
    if labels.shape != (len(F),) or (labels.size and not np.issubdtype(labels.dtype, np.integer)):
        raise MeshError(f"charts must be one integer label per triangle ({len(F)},), got {labels.shape} {labels.dtype}")
    o = _options(boundary, weights, eta, iterations, slide_boundary, max_iterations, min_improvement, solver,
                 stretch_iterations)
    return _native.unwrap_charts(V, F, np.ascontiguousarray(labels, dtype=np.int32), o, progress)


def auto_unwrap(V: npt.ArrayLike, F: npt.ArrayLike, *, target_stretch: float | None = _A.target_stretch,
                max_stretch: float | None = _A.max_stretch, merge: bool = _A.merge, charts: int | None = None, max_charts: int = _A.max_charts, margin: float = _A.margin,
                groups: npt.ArrayLike | None = None, stretch_iterations: int = _D.stretch_iterations,
                progress: Progress | None = None) -> AutoUnwrapResult:
    """One-click unwrap of a closed or complex mesh (dgmesh/charts.h): cut into disk charts, each
    unwrapped by :func:`unwrap` (free boundary, Uopt and the final stretch minimisation), packed
    side by side in [0, 1]^2.

    V: (n, 3), F: (m, 3) a manifold, consistently oriented triangle mesh without zero-area
    triangles (closed or not, any genus, several pieces). The initial charts are a variational
    shape approximation (thesis 4.9; ``charts`` segments, None: automatic), so cuts run where the
    normal turns; a chart that is not a disk (one boundary loop, Euler characteristic 1) is split
    in two. Then the worst chart is split (only its halves are unwrapped again) until the whole
    packed map's L2 stretch (eq. 5.5) is at most ``target_stretch`` and no chart's own exceeds
    ``max_stretch`` (both > 1; None: no bound), or ``max_charts`` charts are reached. ``merge``:
    then join neighbouring charts while the union is a disk and both bounds hold. ``margin``: gap between packed charts, a fraction
    of the layout's side, in [0, 0.25). ``groups``: (m,) integers >= 0, triangles of equal value
    are never cut apart (the triangles of one polygon). ``stretch_iterations``: as :func:`unwrap`.

    Returns :class:`AutoUnwrapResult`: ``uv`` (3m, 2) the UV of corner k of triangle f at row
    3f + k (``uv.reshape(-1, 3, 2)``), ``chart`` (m,) chart of each triangle, ``seams`` (s, 2)
    vertex pairs of the cut edges, ``chart_stretch`` (per chart L2), ``metrics`` (:class:`UvMetrics`
    of the packed map), ``n_charts``, ``initial_charts``, ``topology_splits``, ``stretch_splits``,
    ``merges``, ``seam_length`` and ``edge_length`` (3D), ``uv_area_used`` (of the unit square), ``warnings``.

    Raises MeshError for input that is not such a mesh or options out of range.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    o = AutoUnwrapOptions()
    o.max_stretch = np.inf if max_stretch is None else as_real(max_stretch, "max_stretch", 1.0, lo_open=True)
    o.target_stretch = (np.inf if target_stretch is None
                        else as_real(target_stretch, "target_stretch", 1.0, lo_open=True))
    o.merge = as_flag(merge, "merge")
    o.charts = 0 if charts is None else as_count(charts, "charts", 1)
    o.max_charts = as_count(max_charts, "max_charts", 1)
    o.margin = as_real(margin, "margin", 0.0, 0.25)
    if o.margin >= 0.25:
        raise MeshError(f"margin must be in [0, 0.25), got {margin!r}")
    if groups is not None:
        g = np.asarray(groups)
        if g.shape != (len(F),) or (g.size and (not np.issubdtype(g.dtype, np.integer) or g.min() < 0)):
            raise MeshError(f"groups must be one integer >= 0 per triangle ({len(F)},), got {g.shape} {g.dtype}")
        o.groups = np.ascontiguousarray(g, dtype=np.int32)
    o.unwrap = _options(_D.boundary.name, _D.weights.name, _D.eta, _D.iterations, _D.slide_boundary,
                        _D.max_iterations, _D.min_improvement, _D.solver.name, stretch_iterations)
    return _native.auto_unwrap(V, F, o, progress)


def _as_uv(V, F, UV):
    """Vertex UVs (n, 2) pass through; corner UVs (m, 3, 2) become a triangle soup."""
    UV = np.asarray(UV, dtype=np.float64)
    if UV.ndim == 2 and UV.shape == (len(V), 2):
        return V, F, np.ascontiguousarray(UV)
    if UV.ndim == 3 and UV.shape == (len(F), 3, 2):
        Vs = np.ascontiguousarray(V[F].reshape(-1, 3))
        Fs = np.arange(3 * len(F), dtype=np.int32).reshape(-1, 3)
        return Vs, Fs, np.ascontiguousarray(UV.reshape(-1, 2))
    raise MeshError(
        f"UV must be per vertex ({len(V)}, 2) or per triangle corner ({len(F)}, 3, 2), got {UV.shape}")


def uv_metrics(V: npt.ArrayLike, F: npt.ArrayLike, UV: npt.ArrayLike, *,
               zero_area_eps: float = _D.zero_area_eps) -> UvMetrics:
    """Distortion metrics of thesis 5.3 for a UV map (:class:`UvMetrics`).

    UV: per-vertex (n, 2), or per triangle corner (m, 3, 2) (e.g. a Blender UV map with seams).
    With corner UVs the edge distortion sums over the triangles' sides (interior edges count once
    per side); the other metrics are per triangle and unaffected.
    A triangle is "zero area" when its UV area is at most ``zero_area_eps`` times the total UV
    area; "flipped" counts triangles oriented against the total orientation.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    Vs, Fs, UVs = _as_uv(V, F, UV)
    return _native.uv_metrics(Vs, Fs, UVs, as_real(zero_area_eps, "zero_area_eps", 0.0))


def uv_stretch(V: npt.ArrayLike, F: npt.ArrayLike, UV: npt.ArrayLike, *, uv_faces: npt.ArrayLike | None = None,
               per: str = "vertex", zero_area_eps: float = _D.zero_area_eps) -> np.ndarray:
    """Sander's stretch (normalised, 1 = no stretch) per triangle (``per="face"``) or per vertex
    (``per="vertex"``: eq. 5.1, area-weighted over the incident triangles). UV as in
    :func:`uv_metrics`; or, with ``uv_faces`` (m, 3), any (k, 2) array whose row ``uv_faces[i, j]``
    is corner j of triangle i (a Blender UV map and the loop triangles' loops, without copying
    the UVs per triangle). Zero-area UV triangles have infinite stretch."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    if per not in ("vertex", "face"):
        raise MeshError(f"per must be 'vertex' or 'face', got {per!r}")
    eps = as_real(zero_area_eps, "zero_area_eps", 0.0)
    if uv_faces is None:
        fs = np.asarray(_native.uv_face_stretch(*_as_uv(V, F, UV), eps))
    else:
        UV = np.ascontiguousarray(UV, dtype=np.float64)
        if UV.ndim != 2 or UV.shape[1] != 2:
            raise MeshError(f"UV with uv_faces must have shape (k, 2), got {UV.shape}")
        G = as_faces(uv_faces, name="uv_faces", n=len(UV))
        if len(G) != len(F):
            raise MeshError(f"uv_faces must have one row per triangle ({len(F)}), got {len(G)}")
        fs = np.asarray(_native.uv_face_stretch_indexed(V, F, UV, G, eps))
    if per == "face":
        return fs
    a = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    with np.errstate(invalid="ignore"):
        contrib = np.where(a > 0, a * fs * fs, 0.0)
    num = np.bincount(F.ravel(), weights=np.repeat(contrib, 3), minlength=len(V))
    den = np.bincount(F.ravel(), weights=np.repeat(a, 3), minlength=len(V))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.sqrt(num / np.where(den > 0, den, 1.0)), 0.0)


def chart_labels(n: int, pairs: npt.ArrayLike) -> np.ndarray:
    """Connected components of n items linked by (k, 2) index pairs (union-find, native)."""
    pairs = np.ascontiguousarray(np.asarray(pairs, dtype=np.int32).reshape(-1, 2))
    return np.asarray(_native.connected_labels(int(n), pairs))

