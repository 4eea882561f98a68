"""Low-stretch UV unwrapping by stretch equalization (thesis chapter 5) and UV distortion metrics.

``unwrap`` maps one chart -- a connected triangle mesh of disk topology, possibly with holes -- to
the unit square (or circle, or its natural conformal boundary):

* U0: the longest boundary loop is fixed on a convex polygon (arc-length spaced) and every other
  vertex is a convex combination of its neighbours (eq. 5.2-5.3), with Floater's shape-preserving
  weights by default. With a convex polygon the map has no flipped triangles (Tutte, Floater).
* Stretch equalization: each step divides the weights by the vertex stretch (eq. 5.1, 5.4) raised
  to ``eta`` (eq. 5.6) and solves again. ``iterations="optimal"`` stops when the L2 stretch of
  eq. 5.5 stops decreasing (Uopt); an integer runs exactly that many steps (1 gives U1).
* Holes (inner boundary loops) are filled by a virtual fan for the solves, so they stay open.
* Square corners are placed so that no triangle has all three corners on one side of the square
  (which would give it zero UV area).

Metrics (thesis 5.3), per step and from ``uv_metrics``: ``stretch_l2`` (eq. 5.5, Sander's
normalisation: 1 is an isometry up to scale; infinite when a UV triangle has zero area),
``stretch_linf``, ``stretch_l2_finite`` (eq. 5.5 over the non-degenerate triangles), ``edge``,
``angle`` (mean absolute angle error, radians), ``area``, ``flipped`` and ``zero_area`` counts.
"""

from dataclasses import dataclass, field
from typing import List

import numpy as np

from .core import MeshError, _native, as_count, as_faces, as_real, as_vertices

__all__ = ["UnwrapResult", "unwrap", "uv_metrics", "uv_stretch", "BOUNDARIES", "WEIGHTS", "SOLVERS"]

BOUNDARIES = ("square", "circle", "free")
WEIGHTS = ("floater", "mean_value", "cotangent", "uniform", "auto")
SOLVERS = ("auto", "umfpack", "sparselu", "bicgstab", "multigrid")


@dataclass
class UnwrapResult:
    """Result of :func:`unwrap`.

    uv: (n, 2) float64 UV coordinates of the returned map, inside [0, 1]^2.
    metrics: one dict per step: ``metrics[0]`` is U0, ``metrics[h]`` is U^h (each also holds
        ``seconds`` and ``solver_iterations``). For Uopt the last entry may be the step that was
        rejected because it did not decrease the stretch. U0 and the returned map carry every
        metric; the other steps carry the stretch metrics, flips, zero-area and area distortion,
        with ``edge`` and ``angle`` NaN (not computed, to save time).
    chosen: index into ``metrics`` of the returned map.
    boundary: the boundary actually used ("square", "circle" or "free"; see ``warnings`` for
        fallbacks).
    boundary_convex: whether the fixed polygon is convex (then no triangle can flip).
    n_holes: inner boundary loops, kept open.
    corners: vertex ids placed at the square's corners (0,0), (1,0), (1,1), (0,1).
    warnings: human-readable notes (fallbacks, negative weights).
    solver: linear solver used.
    """

    uv: np.ndarray
    metrics: List[dict]
    chosen: int
    boundary: str
    boundary_convex: bool
    n_holes: int
    corners: List[int] = field(default_factory=list)
    warnings: List[str] = field(default_factory=list)
    solver: str = ""

    @property
    def final(self):
        """Metrics of the returned map."""
        return self.metrics[self.chosen]

    @property
    def initial(self):
        """Metrics of U0."""
        return self.metrics[0]


def _choice(name, value, allowed):
    if value not in allowed:
        raise MeshError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {value!r}")
    return value


def unwrap(V, F, *, boundary="square", weights="floater", eta=1.0, iterations="optimal",
           slide_boundary=False, max_iterations=100, min_improvement=1e-3, solver="auto",
           progress=None) -> UnwrapResult:
    """Low-stretch parameterization of one disk-like chart (thesis chapter 5).

    V: (n, 3) vertex positions, F: (m, 3) triangles (one connected piece of genus 0 with at least
    one boundary loop; every vertex used).
    boundary: "square" (thesis), "circle", or "free" (the natural boundary of the least-squares
        conformal map; falls back to a circle, with a warning, if that boundary folds the map).
    weights: "floater" (shape-preserving, default), "mean_value", "cotangent" (may fold: warns),
        "uniform", or "auto" (beyond the thesis: cotangent, and Floater's from the start again as
        soon as a cotangent map folds or its solve stalls; the lowest stretch on the CGAL disk
        scans, the Blender operator's default).
    eta: strength of each equalization step, 0 < eta <= 1 (eq. 5.6).
    iterations: "optimal" for Uopt, or an int k >= 0 for exactly k steps (0 = U0, 1 = U1).
    slide_boundary: beyond the thesis (whose boundary stays fixed): each step also slides the
        outer boundary vertices along the polygon by a one-dimensional stretch equalization (the
        square's corners stay). The polygon keeps its shape, so no triangle can flip.
    max_iterations: cap on Uopt's steps. min_improvement: Uopt also stops after a step that
        lowers the L2 stretch by less than this fraction.
    solver: "auto" (UMFPACK up to 1000 vertices, multigrid above), "umfpack", "sparselu",
        "bicgstab" (warm-started BiCGSTAB + ILUT) or "multigrid" (warm-started BiCGSTAB with a
        smoothed-aggregation multigrid preconditioner).
    progress: optional callable(fraction) -> bool; returning False raises :class:`Cancelled`.

    Raises MeshError for meshes that are not one disk-like chart (closed, several pieces,
    handles), with a message saying what to do.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    _choice("boundary", boundary, BOUNDARIES)
    _choice("weights", weights, WEIGHTS)
    _choice("solver", solver, SOLVERS)
    if iterations == "optimal":
        it = -1
    else:
        try:
            it = as_count(iterations, "iterations")
        except MeshError:
            raise MeshError(f"iterations must be 'optimal' or an integer >= 0, got {iterations!r}") from None
    eta = float(eta)
    if not (0.0 < eta <= 1.0):
        raise MeshError(f"eta must be in (0, 1], got {eta}")
    r = _native.unwrap(V, F, boundary=boundary, weights=weights, eta=eta, iterations=it,
                       max_iterations=as_count(max_iterations, "max_iterations"), min_improvement=float(min_improvement),
                       solver=solver, slide_boundary=bool(slide_boundary), progress=progress)
    return UnwrapResult(
        uv=np.asarray(r["uv"]),
        metrics=[dict(s) for s in r["steps"]],
        chosen=int(r["chosen"]),
        boundary=r["boundary"],
        boundary_convex=bool(r["boundary_convex"]),
        n_holes=int(r["n_holes"]),
        corners=list(r["corners"]),
        warnings=list(r["warnings"]),
        solver=r["solver"],
    )


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


def uv_metrics(V, F, UV, *, zero_area_eps=1e-10) -> dict:
    """Distortion metrics of thesis 5.3 for a UV map.

    UV: per-vertex (n, 2), or per triangle corner (m, 3, 2) (e.g. a Blender UV map with seams).
    With corner UVs the edge distortion sums over the triangles' sides (interior edges count once
    per side); the other metrics are per triangle and unaffected.
    A triangle is "zero area" when its UV area is at most ``zero_area_eps`` times the total UV
    area; "flipped" counts triangles oriented against the total orientation.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    Vs, Fs, UVs = _as_uv(V, F, UV)
    return dict(_native.uv_metrics(Vs, Fs, UVs, as_real(zero_area_eps, "zero_area_eps", 0.0)))


def uv_stretch(V, F, UV, *, uv_faces=None, per="vertex", zero_area_eps=1e-10) -> np.ndarray:
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


def chart_labels(n, pairs):
    """Connected components of n items linked by (k, 2) index pairs (union-find, native)."""
    pairs = np.ascontiguousarray(np.asarray(pairs, dtype=np.int32).reshape(-1, 2))
    return np.asarray(_native.connected_labels(int(n), pairs))

