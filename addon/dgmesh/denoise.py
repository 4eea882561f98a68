"""Similarity-based mesh denoising (thesis chapter 2) and the bilateral baseline.

The similarity filter is the non-local-means scheme of the thesis (eq. 2.3-2.9): every vertex x
moves along its normal by the similarity-weighted mean of the heights <n_x, y - x> of the points y
within 2 sigma2; the weight of y compares y's neighbourhood with a thin-plate RBF patch fitted
around x (2 sigma3 ball, Gaussian-weighted). sigma_i = eta_i * e with e the average edge length,
re-evaluated every iteration.

Only positions, normals and area elements are used, so the same call handles manifold meshes (with
or without boundary), triangle soups (coincident vertices are welded for the computation and all
copies move identically, so no cracks open) and point clouds with normals (``F=None``).
"""

from dataclasses import dataclass

import numpy as np

from .core import MeshError, _native, as_count, as_faces, as_mask, as_vertices

__all__ = ["DenoiseResult", "denoise", "similarity", "residual_entropy", "METHOD_DEFAULTS"]

# (eta1, eta2, eta3, iterations) per method. Similarity: the thesis's suggested setting (section
# 2.3); bilateral: the thesis's Fandisk setting for [FDCO03] (table 2.1).
METHOD_DEFAULTS = {
    "similarity": (0.4, 1.0, 0.75, 3),
    "bilateral": (0.25, 1.0, 1.0, 3),
}


@dataclass
class DenoiseResult:
    """Result of :func:`denoise`.

    ``vertices``: (n, 3) denoised positions. ``residual``: (n,) per-vertex |x_noisy - x_smoothed|
    (the thesis's comparison scheme). ``residual_entropy``: Shannon entropy in bits of the
    distribution of the residual over the vertices that could move (see
    :func:`residual_entropy`). ``edge_length``: the average edge length e of the last iteration.
    ``rbf_fallbacks``: RBF patches that were ill-conditioned and used a least-squares plane
    instead. ``welded``: coincident vertices merged for the computation.
    """

    vertices: np.ndarray
    residual: np.ndarray
    residual_entropy: float
    edge_length: float
    iterations: int
    method: str
    rbf_fallbacks: int = 0
    welded: int = 0


def denoise(V, F=None, normals=None, *, method="similarity", eta1=None, eta2=None, eta3=None,
            iterations=None, mask=None, progress=None):
    """Denoise a mesh, a triangle soup or a point cloud.

    Parameters
    ----------
    V : (n, 3) vertex positions.
    F : (m, 3) triangles, or None for a point cloud (then ``normals`` is required).
    normals : (n, 3) per-point normals of a point cloud (ignored for meshes, whose normals are
        recomputed every iteration with Nelson Max's weights).
    method : "similarity" (thesis ch. 2) or "bilateral" (Fleishman et al. 2003).
    eta1, eta2, eta3, iterations : sigma_i = eta_i * e. None takes the method's default from
        ``METHOD_DEFAULTS``: similarity 0.4, 1.0, 0.75 and 3 iterations; bilateral 0.25, 1.0, 1.0
        and 3. Similarity: sigma1 is the similarity kernel's deviation (about the noise level),
        2 sigma2 the radius of the averaging domain, 2 sigma3 the radius of the compared patches.
        Bilateral: sigma1 is the height Gaussian, 2 sigma2 the neighbourhood radius, sigma3 the
        spatial Gaussian.
    mask : optional (n,) booleans, True where a vertex may move, or the indices of the vertices that
        may move. Fixed vertices still inform the filter.
    progress : optional callable(fraction) -> bool|None; returning False cancels with
        :class:`dgmesh.Cancelled` (nothing is changed: inputs are never modified).

    Returns
    -------
    DenoiseResult

    Raises MeshError for NaN/inf coordinates, bad indices, no face of positive area, a mask or
    normals of the wrong size, or bad parameters.
    """
    method = str(method).lower()
    if method not in METHOD_DEFAULTS:
        raise MeshError(f"unknown method {method!r} (use 'similarity' or 'bilateral')")
    d1, d2, d3, dn = METHOD_DEFAULTS[method]
    eta1 = d1 if eta1 is None else float(eta1)
    eta2 = d2 if eta2 is None else float(eta2)
    eta3 = d3 if eta3 is None else float(eta3)
    iterations = as_count(dn if iterations is None else iterations, "iterations")
    V = as_vertices(V)
    m = as_mask(mask, len(V))
    m = None if m is None else m.astype(np.uint8)
    if F is None:
        if normals is None:
            raise MeshError("a point cloud (F=None) needs per-point normals")
        N = as_vertices(normals, "normals")
        out = _native.denoise_points(V, N, method, eta1, eta2, eta3, iterations, m, progress)
    else:
        out = _native.denoise_mesh(V, as_faces(F, n=len(V)), method, eta1, eta2, eta3, iterations, m, progress)
    return DenoiseResult(
        vertices=out["vertices"],
        residual=out["residual"],
        residual_entropy=float(out["residual_entropy"]),
        edge_length=float(out["edge_length"]),
        iterations=int(out["iterations"]),
        method=method,
        rbf_fallbacks=int(out["rbf_fallbacks"]),
        welded=int(out["welded"]),
    )


def similarity(V, F, vertex, normals=None, *, eta1=0.4, eta3=0.75, mode="shape", progress=None):
    """Similarity of every vertex to ``vertex`` (thesis fig. 2.1c): (n,) weights in [0, 1].

    The weight is w(x, y) = exp(-D(x, y) / (2 sigma1^2)) (eq. 2.7) with D of eq. 2.9: the
    Gaussian-weighted squared difference between y's neighbourhood and the RBF patch fitted at x
    (sigma_i = eta_i * e). ``mode``:

    * ``"shape"`` (default): y's neighbourhood is taken in y's own frame (its normal, with x's first
      tangent direction carried over), so similar shapes score high wherever they are and however
      they are tilted; this is the map of fig. 2.1c.
    * ``"filter"``: exactly the weights the denoising filter uses, everything in x's frame with
      heights from x's tangent plane; they vanish away from x.

    ``F=None`` means a point cloud with ``normals``. Vertices in no face get 0. ``progress``: as in
    :func:`denoise` (callable(fraction) -> bool|None; False cancels with :class:`Cancelled`).
    """
    if mode not in ("shape", "filter"):
        raise MeshError(f"unknown mode {mode!r} (use 'shape' or 'filter')")
    V = as_vertices(V)
    vertex = as_count(vertex, "vertex")
    shape_only = mode == "shape"
    if F is None:
        if normals is None:
            raise MeshError("a point cloud (F=None) needs per-point normals")
        return _native.similarity_points(V, as_vertices(normals, "normals"), vertex, float(eta1), float(eta3),
                                         shape_only, progress)
    return _native.similarity_mesh(V, as_faces(F, n=len(V)), vertex, float(eta1), float(eta3), shape_only,
                                   progress)


def residual_entropy(residual):
    """Shannon entropy (bits) of the distribution of residual magnitudes: the histogram of
    r / mean(r) over [0, 4) in 64 bins plus an overflow bin (scale-free, 0 .. log2(65))."""
    r = np.ascontiguousarray(residual, dtype=np.float64).ravel()
    return float(_native.residual_entropy(r))
