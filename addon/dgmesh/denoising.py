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

import numpy as np
import numpy.typing as npt

from .core import MeshError, Progress, _native, as_choice, as_count, as_faces, as_mask, as_vertices, make_options

__all__ = ["DenoiseOptions", "DenoiseResult", "DenoiseMethod", "SimilarityOptions", "denoise", "defaults", "similarity",
           "residual_entropy"]

# The contract is the C++ one (dgmesh/denoise.h), bound as it is: the options with their
# defaults, the method enum and the result.
DenoiseOptions = _native.DenoiseOptions
DenoiseResult = _native.DenoiseResult
DenoiseMethod = _native.DenoiseMethod
SimilarityOptions = _native.SimilarityOptions


def defaults(method: str | DenoiseMethod = "similarity") -> DenoiseOptions:
    """The options a method starts from: the thesis's suggested setting for similarity (section
    2.3: eta 0.4, 1.0, 0.75, 3 iterations), its Fandisk setting for bilateral (table 2.1: 0.25,
    1.0, 1.0, 3)."""
    return _native.denoise_defaults(as_choice(method, DenoiseMethod, "method"))


def denoise(V: npt.ArrayLike, F: npt.ArrayLike | None = None, normals: npt.ArrayLike | None = None, *,
            method: str | DenoiseMethod = DenoiseOptions().method.name, eta1: float | None = None,
            eta2: float | None = None, eta3: float | None = None, iterations: int | None = None,
            mask: npt.ArrayLike | None = None, progress: Progress | None = None) -> DenoiseResult:
    """Denoise a mesh, a triangle soup or a point cloud.

    Parameters
    ----------
    V : (n, 3) vertex positions.
    F : (m, 3) triangles, or None for a point cloud (then ``normals`` is required).
    normals : (n, 3) per-point normals of a point cloud (ignored for meshes, whose normals are
        recomputed every iteration with Nelson Max's weights).
    method : "similarity" (thesis ch. 2) or "bilateral" (Fleishman et al. 2003).
    eta1, eta2, eta3, iterations : sigma_i = eta_i * e. None takes the method's default from
        :func:`defaults`. Similarity: sigma1 is the similarity kernel's deviation (about the noise
        level), 2 sigma2 the radius of the averaging domain, 2 sigma3 the radius of the compared
        patches. Bilateral: sigma1 is the height Gaussian, 2 sigma2 the neighbourhood radius,
        sigma3 the spatial Gaussian.
    mask : optional (n,) booleans, True where a vertex may move, or the indices of the vertices that
        may move. Fixed vertices still inform the filter.
    progress : optional callable(fraction) -> bool|None; returning False cancels with
        :class:`dgmesh.Cancelled` (nothing is changed: inputs are never modified).

    Returns
    -------
    DenoiseResult: ``vertices`` (n, 3), ``residual`` (n,) |x_noisy - x_smoothed| per vertex,
    ``residual_entropy`` (bits, see :func:`residual_entropy`), ``edge_length`` (e of the last
    iteration), ``iterations``, ``rbf_fallbacks`` (ill-conditioned RBF patches that used a plane),
    ``welded`` (coincident vertices merged for the computation).

    Raises MeshError for NaN/inf coordinates, bad indices, no face of positive area, a mask or
    normals of the wrong size, or bad parameters.
    """
    o = defaults(method)
    if iterations is not None:
        iterations = as_count(iterations, "iterations")
    make_options(o, eta1=eta1, eta2=eta2, eta3=eta3, iterations=iterations)
    V = as_vertices(V)
    m = as_mask(mask, len(V))
    m = None if m is None else m.astype(np.uint8)
    if F is None:
        if normals is None:
            raise MeshError("a point cloud (F=None) needs per-point normals")
        return _native.denoise_points(V, as_vertices(normals, "normals"), o, m, progress)
    return _native.denoise_mesh(V, as_faces(F, n=len(V)), o, m, progress)


def similarity(V: npt.ArrayLike, F: npt.ArrayLike | None, vertex: int, normals: npt.ArrayLike | None = None, *,
               eta1: float = SimilarityOptions().eta1, eta3: float = SimilarityOptions().eta3, mode: str = "shape",
               progress: Progress | None = None) -> np.ndarray:
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
    o = make_options(SimilarityOptions(), eta1=eta1, eta3=eta3, shape_only=mode == "shape")
    if F is None:
        if normals is None:
            raise MeshError("a point cloud (F=None) needs per-point normals")
        return _native.similarity_points(V, as_vertices(normals, "normals"), vertex, o, progress)
    return _native.similarity_mesh(V, as_faces(F, n=len(V)), vertex, o, progress)


def residual_entropy(residual: npt.ArrayLike) -> float:
    """Shannon entropy (bits) of the distribution of residual magnitudes: the histogram of
    r / mean(r) over [0, 4) in 64 bins plus an overflow bin (scale-free, 0 .. log2(65))."""
    r = np.ascontiguousarray(residual, dtype=np.float64).ravel()
    return float(_native.residual_entropy(r))
