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

from dataclasses import dataclass, field
from typing import List

import numpy as np

from .core import Error, MeshError, _native, as_count, as_faces, as_vertices

__all__ = ["RemeshResult", "remesh", "remesh_full", "point_mesh_distance", "MODES"]

MODES = ("double", "single_u0", "single_uopt")


@dataclass
class RemeshResult:
    """Everything :func:`remesh_full` returns.

    V, F: the new mesh; its first ``n_boundary`` vertices are the boundary, in loop order.
    boundary_source: with ``boundary="keep"``, the input vertex of each boundary vertex (its
        position is copied bit for bit); empty with ``"resample"``.
    uv: output vertices in the triangulation map (U0 for "double" and "single_u0").
    source_face, source_bary: where each output vertex lies on the input, an input face (row of
        F) and the barycentric weights of its three corners, to carry UVs, vertex weights and
        other data over.
    n_interior_target: interior samples asked of the error diffusion (target minus boundary).
    n_rejected: interior samples dropped for being too close to the boundary (last pass).
    passes: error-diffusion passes (the density is rescaled until the count is within 0.2%).
    uopt_iterations: stretch-equalization steps of Uopt.
    n_flips: edge flips made by ``flip_3d``.
    lloyd_iterations: Lloyd relaxation steps made (see ``lloyd_iterations`` of :func:`remesh_full`).
    n_separated: interior samples dropped for lying closer than ``min_separation`` x the local
        target spacing to another sample (last round).
    resolution: the control map's raster size used: the one asked for, or coarser when the target
        is small (error diffusion needs some samples per hundred pixels, at most 256 pixels each).
    sampling_rounds: diffusion + relaxation + separation rounds (repeated with a raised diffusion
        goal while the separation drops more than 0.5% of the target).
    smooth_moves: vertex moves made by ``smooth_iterations``.
    n_removed: interior vertices of valence 3 or 4 with an angle under 20 degrees in their star,
        removed by ``smooth_iterations`` (their star becomes its link).
    seconds: wall time of the stages (parameterize, sample, triangulate).
    warnings: human-readable notes (e.g. resolution too low for the target).
    """

    V: np.ndarray
    F: np.ndarray
    n_boundary: int
    boundary_source: np.ndarray
    uv: np.ndarray
    n_interior_target: int
    n_rejected: int
    passes: int
    uopt_iterations: int
    n_flips: int = 0
    lloyd_iterations: int = 0
    n_separated: int = 0
    resolution: int = 0
    sampling_rounds: int = 0
    smooth_moves: int = 0
    n_removed: int = 0
    seconds: dict = field(default_factory=dict)
    warnings: List[str] = field(default_factory=list)
    source_face: np.ndarray = None
    source_bary: np.ndarray = None


def remesh_full(V, F, *, target_vertices, adaptivity=0.0, resolution=256, mode="double",
                boundary="keep", domain="circle", boundary_clearance=0.5, flip_3d=True,
                eta=1.0, uopt_steps=-1, lloyd_iterations=30, relax_metric="surface",
                min_separation=0.35, smooth_iterations=3, progress=None) -> RemeshResult:
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
    boundary_clearance, eta, uopt_steps, domain: see RemeshOptions in remesh.h.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    if mode not in MODES:
        raise MeshError(f"mode must be one of {', '.join(map(repr, MODES))}, got {mode!r}")
    if boundary not in ("keep", "resample"):
        raise MeshError(f"boundary must be 'keep' or 'resample', got {boundary!r}")
    if domain not in ("circle", "square"):
        raise MeshError(f"domain must be 'circle' or 'square', got {domain!r}")
    target_vertices = as_count(target_vertices, "target_vertices")
    resolution = as_count(resolution, "resolution")
    uopt_steps = as_count(uopt_steps, "uopt_steps", -1)
    lloyd_iterations = as_count(lloyd_iterations, "lloyd_iterations")
    smooth_iterations = as_count(smooth_iterations, "smooth_iterations")

    def run(clearance):
        return _native.remesh(V, F, target_vertices, adaptivity=float(adaptivity), resolution=resolution,
                              mode=mode, boundary=boundary, domain=domain,
                              boundary_clearance=float(clearance), flip_3d=bool(flip_3d),
                              eta=float(eta), uopt_steps=uopt_steps, lloyd_iterations=lloyd_iterations,
                              relax_metric=str(relax_metric), min_separation=float(min_separation),
                              smooth_iterations=smooth_iterations, progress=progress)

    try:
        r = run(boundary_clearance)
        retried = None
    except Error as exc:
        # A safety net: samples close to the boundary can keep the map's Delaunay triangulation from
        # meeting a resampled boundary (the ears of a kept one are triangulated apart; Add > Grid 60x60
        # at 30000 vertices on 256^2 needed this before): once more with the boundary samples' full
        # clearance.
        if "triangulation is invalid" not in str(exc) or boundary_clearance >= 1.0:
            raise
        try:
            r = run(1.0)
        except Error as exc2:
            if "triangulation is invalid" not in str(exc2) or boundary != "keep":
                raise
            # No known case left (the left half of a subdivided lion-head was one: needle ears side by
            # side, now triangulated apart); what the user can do is change the border.
            raise MeshError("remesh: the new triangulation could not be stitched to the kept boundary of this "
                            "region; select a region with a smoother border, or remesh the whole disk with the "
                            "boundary resampled (boundary='resample'; Object mode: Resample Boundary)") from None
        retried = ("the first triangulation missed the kept boundary: remeshed again with more room between the "
                   f"boundary and the inner vertices (boundary_clearance {boundary_clearance:g} -> 1)")
    return RemeshResult(
        V=np.asarray(r["V"]), F=np.asarray(r["F"]), n_boundary=int(r["n_boundary"]),
        boundary_source=np.asarray(r["boundary_source"], dtype=np.int64), uv=np.asarray(r["uv"]),
        n_interior_target=int(r["n_interior_target"]), n_rejected=int(r["n_rejected"]),
        passes=int(r["passes"]), uopt_iterations=int(r["uopt_iterations"]), n_flips=int(r["n_flips"]),
        lloyd_iterations=int(r["lloyd_iterations"]), n_separated=int(r["n_separated"]),
        sampling_rounds=int(r["sampling_rounds"]), resolution=int(r["resolution"]), smooth_moves=int(r["smooth_moves"]), n_removed=int(r["n_removed"]),
        seconds=dict(parameterize=r["seconds_parameterize"], sample=r["seconds_sample"],
                     relax=r["seconds_relax"], triangulate=r["seconds_triangulate"]),
        warnings=list(r["warnings"]) + ([retried] if retried else []),
        source_face=np.asarray(r["source_face"], dtype=np.int64), source_bary=np.asarray(r["source_bary"]))


def remesh(V, F, *, target_vertices, adaptivity=0.0, resolution=256, mode="double", boundary="keep",
           progress=None):
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


def point_mesh_distance(P, V, F, *, candidates=16):
    """Distance from each point of P (k, 3) to the triangle mesh (V, F): exact distances to the
    triangles whose centroids are among the ``candidates`` nearest (so it can only over-estimate)."""
    V = as_vertices(V)
    P = as_vertices(P, "P")
    if not np.isfinite(P).all():
        raise MeshError("P has NaN or infinite coordinates")
    return np.asarray(_native.point_mesh_distance(P, V, as_faces(F, n=len(V)),
                                                  as_count(candidates, "candidates", 1)))
