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

__all__ = ["DenoiseOptions", "DenoiseResult", "DenoiseMethod", "SimilarityOptions", "NoiseOptions", "NoiseEstimate",
           "denoise", "defaults", "similarity", "estimate_noise", "residual_entropy"]

# The contract is the C++ one (dgmesh/denoise.h), bound as it is: the options with their
# defaults, the method enum and the result.
DenoiseOptions = _native.DenoiseOptions
DenoiseResult = _native.DenoiseResult
DenoiseMethod = _native.DenoiseMethod
SimilarityOptions = _native.SimilarityOptions
NoiseOptions = _native.NoiseOptions
NoiseEstimate = _native.NoiseEstimate


def defaults(method: str | DenoiseMethod = "similarity") -> DenoiseOptions:
    """The options a method starts from: the thesis's suggested setting for similarity (section
    2.3: eta 0.4, 1.0, 0.75, 3 iterations), its Fandisk setting for bilateral (table 2.1: 0.25,
    1.0, 1.0, 3)."""
    return _native.denoise_defaults(as_choice(method, DenoiseMethod, "method"))


def denoise(V: npt.ArrayLike, F: npt.ArrayLike | None = None, normals: npt.ArrayLike | None = None, *,
            method: str | DenoiseMethod = DenoiseOptions().method.name, automatic: bool | None = None,
            eta1: float | None = None, eta2: float | None = None, eta3: float | None = None,
            iterations: int | None = None, quadratic_fit: bool | None = None, mask: npt.ArrayLike | None = None,
            progress: Progress | None = None) -> DenoiseResult:
    """Denoise a mesh, a triangle soup or a point cloud.

    Parameters
    ----------
    V : (n, 3) vertex positions.
    F : (m, 3) triangles, or None for a point cloud (then ``normals`` is required).
    normals : (n, 3) per-point normals of a point cloud (ignored for meshes, whose normals are
        recomputed every iteration with Nelson Max's weights).
    method : "similarity" (thesis ch. 2) or "bilateral" (Fleishman et al. 2003).
    automatic : True: estimate the noise (:func:`estimate_noise`) and take eta1, iterations and
        quadratic_fit from the rule of ``_native.auto_options`` (reported in the result's ``noise``
        and ``options``); eta2 and eta3 are used as given. Similarity on meshes: where the
        estimate asks for smoothing (``_native.auto_smoothing_steps``) and the filtered mesh shows
        no sharp features (``_native.shows_features``), the input is Taubin-smoothed instead of
        filtered (``options.smoothing_steps`` > 0, ``iterations`` 0 in the result); where it asks
        for no step (noise small against the shape detail, e.g. noise-free input) the mesh is
        returned unchanged (both 0). False: every
        parameter as given (no smoothing). None (default): automatic unless eta1, iterations or
        quadratic_fit is given.
    eta1, eta2, eta3, iterations : sigma_i = eta_i * e. None takes the method's default from
        :func:`defaults`. Similarity: sigma1 is the similarity kernel's deviation (about the noise
        level), 2 sigma2 the radius of the averaging domain, 2 sigma3 the radius of the compared
        patches. Bilateral: sigma1 is the height Gaussian, 2 sigma2 the neighbourhood radius,
        sigma3 the spatial Gaussian.
    quadratic_fit : similarity only: fit a similarity-weighted quadratic to the heights and move to
        its value (local quadratic regression) instead of their weighted mean (eq. 2.4), so that
        curvature is not flattened as if it were noise.
    mask : optional (n,) booleans, True where a vertex may move, or the indices of the vertices that
        may move. Fixed vertices still inform the filter.
    progress : optional callable(fraction) -> bool|None; returning False cancels with
        :class:`dgmesh.Cancelled` (nothing is changed: inputs are never modified).

    Returns
    -------
    DenoiseResult: ``vertices`` (n, 3), ``residual`` (n,) |x_noisy - x_smoothed| per vertex,
    ``residual_entropy`` (bits, see :func:`residual_entropy`), ``edge_length`` (e of the last
    iteration), ``iterations``, ``rbf_fallbacks`` (ill-conditioned RBF patches that used a plane),
    ``welded`` (coincident vertices merged for the computation), ``noise`` (the
    :class:`NoiseEstimate` in automatic mode), ``options`` (the options the filter ran with).

    Raises MeshError for NaN/inf coordinates, bad indices, no face of positive area, a mask or
    normals of the wrong size, bad parameters, or (automatic mode) fewer than 19 distinct points
    to estimate the noise from.
    """
    o = defaults(method)
    if iterations is not None:
        iterations = as_count(iterations, "iterations")
    if automatic is None:
        automatic = o.automatic and eta1 is None and iterations is None and quadratic_fit is None
    make_options(o, automatic=automatic, eta1=eta1, eta2=eta2, eta3=eta3, iterations=iterations,
                 quadratic_fit=quadratic_fit)
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


def estimate_noise(V: npt.ArrayLike, F: npt.ArrayLike | None = None, *,
                   neighbours: int = NoiseOptions().neighbours, progress: Progress | None = None) -> NoiseEstimate:
    """Estimate the noise level of a mesh, triangle soup (``F`` given) or point cloud (``F=None``).

    Around every point a cubic height function is fitted by least squares to its
    ``neighbours`` nearest points (19: a regular mesh's 2-ring) over their principal-component
    plane; the point's residual divided by sqrt(1 - leverage) is exactly N(0, sigma^2) for
    independent height noise, and sigma is 1.4826 times the median of their magnitudes, so
    curvature (taken by the cubic) and sharp features (outvoted in the median) do not read as
    noise. Noise along the normals and isotropic noise both give sigma (the normal component).

    Returns
    -------
    NoiseEstimate: ``sigma`` (in units of the mean edge length ``edge_length``, the unit of the
    denoising etas), ``sigma_abs`` (model units), ``edge_length`` (point clouds: mean distance to
    the 6 nearest points), ``curvature`` (median of edge length times the fits' largest absolute
    principal curvature: how coarse the sampling is for the surface), ``outliers`` (fraction of
    points beyond 3 sigma: sharp features, spikes), ``detail`` (sqrt(max(0, sigma_wide^2 -
    sigma^2)) with sigma_wide read by fits of 2 ``neighbours`` - 2 points: shape detail at the
    sampling scale, which noise alone does not raise), ``samples``.

    Raises MeshError for NaN/inf coordinates, bad indices, no face of positive area, fewer distinct
    points than ``neighbours``, or ``neighbours`` outside [12, 64]. ``progress`` as in :func:`denoise`.
    """
    o = make_options(NoiseOptions(), neighbours=neighbours)
    V = as_vertices(V)
    if F is None:
        return _native.estimate_noise_points(V, o, progress)
    return _native.estimate_noise_mesh(V, as_faces(F, n=len(V)), o, progress)


def residual_entropy(residual: npt.ArrayLike) -> float:
    """Shannon entropy (bits) of the distribution of residual magnitudes: the histogram of
    r / mean(r) over [0, 4) in 64 bins plus an overflow bin (scale-free, 0 .. log2(65))."""
    r = np.ascontiguousarray(residual, dtype=np.float64).ravel()
    return float(_native.residual_entropy(r))
