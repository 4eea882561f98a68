"""Remeshing of a disk chart by double parameterization (thesis 5.4, after Alliez, Meyer and
Desbrun 2002, "Interactive geometry remeshing").

``remesh`` parameterizes the chart twice -- U0 (Floater's shape-preserving weights, close to
conformal) and Uopt (stretch equalization, close to area-preserving), both with the boundary on the
unit circle -- rasterizes the control map (3D area / UV area, times a curvature density blended in by
``adaptivity``) over the sampling map in software, samples it by serpentine Floyd-Steinberg error
diffusion so that the expected count is ``target_vertices`` minus the boundary vertices, relaxes the
samples by a few density-weighted Lloyd steps (boundary fixed), maps the
samples to the triangulation map through the shared triangulation, Delaunay-triangulates them there
(Qhull) and lifts the triangles to 3D.

Modes (thesis fig. 5.6-5.9): ``"double"`` samples on Uopt and triangulates on U0 (the thesis's
scheme); ``"single_u0"`` and ``"single_uopt"`` sample and triangulate on one map.
"""

import numpy as np
import numpy.typing as npt

from .core import MeshError, Progress, _native, as_count, as_faces, as_vertices, make_options

__all__ = ["RemeshOptions", "RemeshResult", "RemeshMode", "RemeshBoundary", "RemeshRelaxMetric", "remesh",
           "remesh_full", "point_mesh_distance"]

# The contract is the C++ one (dgmesh/remesh.h), bound as it is: the options with their defaults,
# the enums and the result. The parameter domain (``domain``) is unwrap's UvBoundary.
RemeshOptions = _native.RemeshOptions
RemeshResult = _native.RemeshResult
RemeshMode = _native.RemeshMode
RemeshBoundary = _native.RemeshBoundary
RemeshRelaxMetric = _native.RemeshRelaxMetric
_D = RemeshOptions()


def remesh_full(V: npt.ArrayLike, F: npt.ArrayLike, *, target_vertices: int, adaptivity: float = _D.adaptivity,
                resolution: int = _D.resolution, mode: str | RemeshMode = _D.mode.name,
                boundary: str | RemeshBoundary = _D.boundary.name, domain: str | _native.UvBoundary = _D.domain.name,
                boundary_clearance: float = _D.boundary_clearance, flip_3d: bool = _D.flip_3d, eta: float = _D.eta,
                uopt_steps: int = _D.uopt_steps, lloyd_iterations: int = _D.lloyd_iterations,
                relax_metric: str | RemeshRelaxMetric = _D.relax_metric.name,
                min_separation: float = _D.min_separation, smooth_iterations: int = _D.smooth_iterations,
                progress: Progress | None = None) -> RemeshResult:
    """:func:`remesh` with all options and diagnostics; see there for the common ones.

    lloyd_iterations: density-weighted Lloyd steps after the error diffusion (Lloyd 1982; the
        centroidal Voronoi sampling of Alliez et al. 2003, "Isotropic surface remeshing"): every interior sample moves to the control-map mass
        centroid of its Voronoi cell (with the surface metric: the 3D centroid, within the cell's mean
        tangent plane, pulled onto the surface),
        integrated over a grid of the sampling map with ~32 points a cell (up to 1024^2), boundary
        samples fixed. At most this many steps: they end when the samples' RMS move falls under
        0.3% of the local target spacing (fewer leave the sampling map's own error-diffusion
        pattern, stretched on the surface as the map is, in the samples). 0 is the thesis's plain
        error diffusion. The same step for all three modes.
    relax_metric: "surface" (Voronoi cells by 3D distance, default) or "map" (by distance in the
        sampling map, which is anisotropic on the surface where the map is).
    min_separation: after relaxing, interior samples closer in 3D than this fraction of the target
        spacing to another sample are dropped (0 disables); a warning says how many when it is more
        than 1% (the sampling map is too coarse there for the target).
    flip_3d: 3D Delaunay edge flips after the triangulation (across near-flat edges, where the
        flip unfolds a fold, or where it raises the smallest angle of a pair holding one under 20
        degrees), keeping the embedding in the triangulation map. Default on.
    smooth_iterations: sweeps of tangential smoothing of the new mesh's interior vertices in the
        surface metric (towards the area-weighted mean of their triangles' circumcentres, the
        optimal-Delaunay step), moved inside the triangulation map so they stay on the input surface
        and no map triangle flips; a move may not create a 3D angle below 35 degrees (33 on sharp
        features, whose vertices only move to lift such an angle) and stars still holding one get a
        max-min-angle pattern search; each sweep is followed by the 3D flips when ``flip_3d`` and by
        the removal of interior valence-3/4 vertices whose star holds an angle under 20 degrees
        (``n_removed``), then a closing sweep without flips. Default 3; 0 (with
        ``flip_3d=False, lloyd_iterations=0``) is the thesis's scheme as published.
    boundary_clearance, eta, uopt_steps, domain: see :class:`RemeshOptions` (dgmesh/remesh.h), whose
        defaults every option takes.

    Returns a :class:`RemeshResult`: ``V``, ``F``, the new mesh, its first ``n_boundary`` vertices the
    boundary in loop order; ``boundary_source``, with ``boundary="keep"`` the input vertex of each
    boundary vertex (its position copied bit for bit), empty with ``"resample"``; ``uv``, the output
    vertices in the triangulation map (U0 for "double" and "single_u0"); ``source_face``,
    ``source_bary``, where each output vertex lies on the input (an input face and the barycentric
    weights of its corners, to carry UVs, weights and other data over); ``n_interior_target``,
    ``n_rejected`` (dropped by the boundary clearance, last pass), ``passes`` (error-diffusion
    passes), ``uopt_iterations``, ``n_flips``, ``lloyd_iterations``, ``n_separated`` (dropped by
    ``min_separation``, last round), ``resolution`` (the raster size used: the one asked for, or
    coarser when the target is small), ``sampling_rounds``, ``smooth_moves``, ``n_removed``
    (interior valence-3/4 vertices removed by the smoothing), the stages' wall times
    ``seconds_parameterize``, ``seconds_sample``, ``seconds_relax``, ``seconds_triangulate``, and
    ``warnings`` (notes for the user, e.g. a resolution too low for the target).
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    o = make_options(RemeshOptions(), target_vertices=as_count(target_vertices, "target_vertices"),
                     adaptivity=adaptivity, resolution=as_count(resolution, "resolution"), mode=mode,
                     boundary=boundary, domain=domain, flip_3d=flip_3d, eta=eta,
                     uopt_steps=as_count(uopt_steps, "uopt_steps", -1),
                     lloyd_iterations=as_count(lloyd_iterations, "lloyd_iterations"), relax_metric=relax_metric,
                     min_separation=min_separation, smooth_iterations=as_count(smooth_iterations, "smooth_iterations"),
                     boundary_clearance=boundary_clearance)
    # A triangulation that misses the boundary is retried in dgmesh::remesh (detail/remesh_retry.h).
    return _native.remesh(V, F, o, progress)


def remesh(V: npt.ArrayLike, F: npt.ArrayLike, *, target_vertices: int, adaptivity: float = _D.adaptivity,
           resolution: int = _D.resolution, mode: str | RemeshMode = _D.mode.name,
           boundary: str | RemeshBoundary = _D.boundary.name,
           progress: Progress | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Remesh one disk-shaped chart with about ``target_vertices`` vertices (thesis 5.4).

    V: (n, 3) vertex positions; F: (m, 3) triangles forming one piece with one boundary loop and
        no handles (every vertex used).
    target_vertices: total vertices of the result, boundary included (met within about 1% when the
        resolution allows it: at most one sample per pixel, so keep it well below resolution^2 / 4).
    adaptivity: 0 for a uniform density over the surface; up to 1 for a density proportional to the
        curvature sqrt(k1^2 + k2^2) (clipped at 8x its mean).
    resolution: the control map is resolution x resolution pixels (16..4096; 128..1024 is typical).
    mode: "double" (sample on Uopt, Delaunay on U0), "single_u0" or "single_uopt".
    boundary: "keep" (default) keeps the input's boundary vertices bit for bit and in order, so the
        result can be stitched back into a larger mesh; "resample" places new boundary vertices
        along the boundary polyline at the target spacing.
    progress: optional callable(fraction) -> bool; returning False raises :class:`Cancelled`.

    Returns (V, F): the first vertices are the boundary in loop order, faces are oriented like the
    input. Raises MeshError for non-disk input (closed, annulus or holes, several pieces, handles),
    bad options, or a target not above the number of kept boundary vertices.
    """
    r = remesh_full(V, F, target_vertices=target_vertices, adaptivity=adaptivity, resolution=resolution,
                    mode=mode, boundary=boundary, progress=progress)
    return r.V, r.F


def point_mesh_distance(P: npt.ArrayLike, V: npt.ArrayLike, F: npt.ArrayLike, *, candidates: int = 16) -> np.ndarray:
    """Distance from each point of P (k, 3) to the triangle mesh (V, F): exact distances to the
    triangles whose centroids are among the ``candidates`` nearest (so it can only over-estimate)."""
    V = as_vertices(V)
    P = as_vertices(P, "P")
    if not np.isfinite(P).all():
        raise MeshError("P has NaN or infinite coordinates")
    return np.asarray(_native.point_mesh_distance(P, V, as_faces(F, n=len(V)),
                                                  as_count(candidates, "candidates", 1)))
