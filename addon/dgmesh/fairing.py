"""Fairing by the discrete Willmore flow, hole restoration and tangential regularisation
(thesis chapter 3).

``fair`` moves vertices to decrease the elastica energy (the integral of H^2 dA, "Willmore
energy"): a sphere stays a sphere, an elongated closed shape rounds up, a patch filled into a
hole blends smoothly into the surrounding surface. ``regularize`` only slides vertices in their
tangent planes to even out triangle sizes and shapes.
"""

import numpy as np
import numpy.typing as npt

from .core import Progress, _native, as_choice, as_count, as_faces, as_mask, as_real, as_vertices, make_options

__all__ = ["FairOptions", "FairResult", "FairMethod", "FairScheme", "FairBoundary", "FairStall", "FairStartWeights", "RegularizeOptions", "fair",
           "defaults", "regularize", "willmore_energy", "subdivide_region", "refine_region"]

# The contract is the C++ one (dgmesh/fair.h), bound as it is: the options with their defaults,
# the enums and the result.
FairOptions = _native.FairOptions
FairResult = _native.FairResult
FairMethod = _native.FairMethod
FairScheme = _native.FairScheme
FairBoundary = _native.FairBoundary
FairStall = _native.FairStall
FairStartWeights = _native.FairStartWeights
RegularizeOptions = _native.RegularizeOptions
_D = FairOptions()
_R = RegularizeOptions()


def defaults(scheme: str | FairScheme = _D.scheme.name) -> FairOptions:
    """The options a scheme starts from: ``FairOptions()`` (300 iterations per level) for
    "semi_implicit"; 5000 iterations per level for "explicit", whose steps are far smaller."""
    return _native.fair_defaults(as_choice(scheme, FairScheme, "scheme"))


def fair(V: npt.ArrayLike, F: npt.ArrayLike, *, method: str | FairMethod = _D.method.name,
         mask: npt.ArrayLike | None = None, faces: npt.ArrayLike | None = None,
         boundary: str | FairBoundary = _D.boundary.name, subdivisions: int = _D.subdivisions,
         tolerance: float = _D.tolerance, min_progress: float = _D.min_progress, max_iterations: int | None = None, tangential: bool = _D.tangential,
         scheme: str | FairScheme = _D.scheme.name, max_seconds: float = _D.max_seconds,
         step_scale: float = _D.step_scale, linear_start: bool = _D.linear_start,
         start_weights: str | FairStartWeights = _D.start_weights.name, refine: bool = _D.refine,
         keep_size: bool = _D.keep_size, progress: Progress | None = None) -> FairResult:
    """Fair a triangle mesh (or a region of it) by a curvature flow.

    Every option's default is :class:`FairOptions`'s (dgmesh/fair.h).

    method: "willmore" (the default, below) or "hinge": the edge-based discrete Willmore energy
        sum_e 3 theta_e^2 |e|^2 / A_e (theta_e the dihedral angle at edge e, A_e its two faces' area;
        Grinspun et al. 2003), minimised by Levenberg-Marquardt over the movable vertices from the
        bilaplacian steady state U0^2 P = 0; a crease along the fixed rim is charged at its cost
        (issue 30: closer to the original than the Willmore flow on the damaged regions of bench
        fair_repair, less close on hole fills, see bench/notes/fair.md). Needs fixed
        vertices: a mesh faired whole gets the Willmore flow; scheme, tangential and step_scale do
        not apply, ``energy`` holds the hinge energy. "willmore": the thesis's flow (eq. 3.5: speed
        -Lap(H) - 2H(H^2-K) along the normal, plus the tangential drift of eq. 3.10),
        "laplacian_of_h" (eq. 3.12) or "bilaplacian" (P <- P - tau U0^2(P)), the thesis's
        comparison flows.
    mask: vertices allowed to move (bool per vertex, or indices). The fixed vertices next to them
        keep position and tangent plane, so a filled hole blends smoothly (G1) into the surface.
        None: the whole mesh moves (mesh-boundary vertices per ``boundary``).
    faces: faces refined by ``subdivisions`` (bool per face or indices); default: the faces
        touching a movable vertex. Edges shared with faces outside are not split, so the rest of
        the mesh keeps its topology. A hole filled without interior vertices (one n-gon, a fan)
        needs ``faces`` and ``subdivisions >= 1``: the new edge midpoints are the ones that move.
    boundary: "fixed" or "sliding" (boundary vertices slide along the boundary curve).
    subdivisions: coarse-to-fine levels (0..6): fair, refine 1-to-4 (linear), fair again (fig. 3.5); each
        refined level first puts its new midpoints at the minimiser of the linearised (cotangent
        bi-Laplacian) energy with the old vertices held, when that lowers the energy (counted as
        an iteration), so it does not spend its iterations on the split's creases.
    tolerance: stop when the relative energy change over a window of flow time falls below it
        (semi-implicit: also when 16 accepted steps found no energy lower by this fraction than
        the lowest before them; ``converged`` is then False if the energy had crept up).
    min_progress: semi-implicit "willmore" / "laplacian_of_h": a level also stops (converged) when
        the energy fell over its last 8 accepted steps by less than this fraction of the smaller
        of its fall since the level's input and the energy left (a flow creeping after its drop;
        issue 30's speed case). Regions only: not for a part without fixed vertices (a closed
        object faired whole), nor for the flow from the input when the linear start was declined
        (the restart judges how far it gets). 0: off.
    max_iterations: per level; None: the scheme's default (:func:`defaults`: 300 semi-implicit,
        5000 explicit).
    tangential: add the tangential drift that equalises triangles (eq. 3.8).
    scheme: "semi_implicit" (default: a linearised implicit bi-Laplacian step, same fixed points,
        far larger steps) or "explicit" (the thesis's forward Euler with tau = A_min^2 / 150).
    max_seconds: wall-clock budget (0 = none). step_scale: multiplies the explicit time step.
    linear_start: with fixed vertices (region mode, fixed boundary), "willmore" and
        "laplacian_of_h" first jump to the minimiser of the linearised energy (U0^2 P = 0 with
        the fixed rings as boundary data, the bilaplacian flow's steady state) when that lowers
        the Willmore energy, then flow from there. A flat hole fill has a crease along its rim
        that costs little discrete energy on a coarse mesh, and the flow alone stays near it.
        "hinge" always starts there (off: from the input).
    start_weights: the weights of that linearised minimiser: "uniform" (U0^2, the connectivity
        only) or "cotangent" (the cotangent bi-Laplacian L M^-1 L with the cotangent weights and
        mixed areas of the input geometry, the system CGAL's PMP::fair solves: a dented region
        keeps the metric of the surface it was pushed from, a flattened one the projection's:
        closer on some dents, farther on most flattened regions, bench/notes/fair.md; the
        uniform start when a vertex next to the region has no area or the solve fails).
    refine: region mode only: before the flow, refine the region's faces like Liepa's hole
        filling (split triangles larger than the mesh around the hole at their centroid, Delaunay
        edge flips inside the region, until the patch's triangles match the border's edge
        lengths). For a coarse fill (Fill, a fan, a grid with few vertices); the region's border
        edges are never split, the new vertices move. A fill already as fine as the mesh around it
        (a small hole) is subdivided once instead, when ``subdivisions`` is 0.
    keep_size: "willmore" and "laplacian_of_h": a connected component without fixed vertices (a
        closed object faired whole) keeps its centroid and surface area. Both flows are
        scale-equivariant and the energy is invariant under similarities, so this changes neither
        the energy nor the shape, only where and how large the result is (without it the flow also
        shrinks, grows or moves a closed object). The bilaplacian flow shrinks a closed object
        towards a point either way.
    progress: callable(fraction) -> bool/None; returning False cancels (raises Cancelled).

    Returns a :class:`FairResult`: ``vertices`` (n', 3), the input's vertices keeping their indices
    (fixed ones exactly unchanged), new vertices from subdivision following; ``faces`` (m', 3), row
    f < m holding a child of input face f (or f itself), the extra children following;
    ``face_origin`` (m',) the input face of each output face; ``energy``, the Willmore energy after
    each iteration (``energy[0]`` the input's, of the faired region and its first fixed ring in
    region mode); ``moved`` (n',) bool, the vertices free to move; ``iterations``,
    ``level_iterations``, ``converged``, ``lam`` (the last H rescaling factor), ``linear_start``
    (the flow started from the linearised minimiser, counted as iteration 1), ``energy_rose``
    (some level ended above its start energy, a mesh the flow cannot improve: slivers,
    fan-triangulated caps; that level's lowest-energy state was returned), ``restarted`` (the flow
    from the input moved no vertex by a quarter of the way to the linearised minimiser, which lies
    over an edge away: a flattened or dented region, a discrete minimum whose crease along the fixed rim costs
    little energy; the level was run again from the linearised minimiser and kept, even above the
    input's energy), ``stall`` (a :class:`FairStall`: "none", or "no_descent" when no vertex moved,
    "no_change" when no level lowered its energy by 10 x tolerance: the flow did not change the
    region; a larger region, ``refine``/``subdivisions`` or another method may), ``start_fallback``
    (``start_weights="cotangent"`` was asked for but the uniform start was used: a vertex next to
    the region without area, a failed solve, or a part without fixed vertices) and ``subdivided``.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    o = defaults(scheme)
    make_options(o, method=method, boundary=boundary, tolerance=tolerance, min_progress=min_progress, tangential=tangential,
                 max_seconds=max_seconds, step_scale=step_scale, linear_start=linear_start,
                 start_weights=as_choice(start_weights, FairStartWeights, "start_weights"), refine=refine,
                 keep_size=keep_size, subdivisions=as_count(subdivisions, "subdivisions"),
                 max_iterations=None if max_iterations is None else as_count(max_iterations, "max_iterations"))
    vm = as_mask(mask, len(V), "mask")
    fm = as_mask(faces, len(F), "faces")
    # A face mask alone, and regions in independent parts (each faired with its own step
    # control): handled by dgmesh::fair (fair.h), so C++ and Python callers get the same result.
    return _native.fair(V, F, o, vm, fm, progress)


def regularize(V: npt.ArrayLike, F: npt.ArrayLike, *, iterations: int = _R.iterations,
               mask: npt.ArrayLike | None = None, boundary: str | FairBoundary = _R.boundary.name,
               step_scale: float = _R.step_scale, project: bool = _R.project,
               progress: Progress | None = None) -> np.ndarray:
    """Tangential regularisation (thesis eq. 3.8 with tau = 0, fig. 3.3-3.4): vertices drift in
    their tangent planes by the tangent part of the area-weighted bi-umbrella operator, which
    evens out triangle sizes and shapes while keeping the surface. Returns the new (n, 3)
    positions; vertices outside ``mask`` (bool per vertex or indices) are unchanged.
    ``step_scale`` multiplies the thesis's step (12 times the smallest triangle area within two
    rings). ``project`` puts moved vertices back onto the input surface after each step (the drift
    alone leaves a curved surface by O(step^2 * curvature) per step). The defaults are
    :class:`RegularizeOptions`'s."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    o = make_options(RegularizeOptions(), iterations=as_count(iterations, "iterations"), boundary=boundary,
                     step_scale=step_scale, project=project)
    return _native.regularize(V, F, o, as_mask(mask, len(V), "mask"), progress)


def willmore_energy(V: npt.ArrayLike, F: npt.ArrayLike) -> float:
    """Discrete Willmore energy sum H_i^2 A_i (mixed areas): 4 pi for a sphere, 2 pi^2 for the
    torus with radii ratio sqrt(2)."""
    return _native.willmore_energy(as_vertices(V), as_faces(F))


def subdivide_region(V: npt.ArrayLike, F: npt.ArrayLike,
                     faces: npt.ArrayLike | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear 1-to-4 subdivision of the faces selected by ``faces`` only; edges shared with other
    faces are not split (the faces along the border become 2 or 3 triangles). Returns
    (V, F, face_origin)."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    fm = as_mask(faces, len(F), "faces")
    if fm is None:
        fm = np.ones(len(F), dtype=bool)
    return _native.subdivide_region(V, F, fm)


def refine_region(V: npt.ArrayLike, F: npt.ArrayLike, faces: npt.ArrayLike | None,
                  density: float = 2 ** 0.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Liepa-style refinement of the faces selected by ``faces`` (a hole fill): triangles larger
    than the mesh around the region are split at their centroid and region-interior edges are
    flipped to Delaunay until the triangles match the border's edge lengths (``density`` is
    Liepa's alpha). The region's border edges are never split or flipped and faces outside keep
    their rows. Returns (V, F, face_origin); new vertices follow the input's."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    fm = as_mask(faces, len(F), "faces")
    if fm is None:
        fm = np.ones(len(F), dtype=bool)
    return _native.refine_region(V, F, fm, as_real(density, "density", 0.0, lo_open=True))
