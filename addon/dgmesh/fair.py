"""Fairing by the discrete Willmore flow, hole restoration and tangential regularisation
(thesis chapter 3).

``fair`` moves vertices to decrease the elastica energy (the integral of H^2 dA, "Willmore
energy"): a sphere stays a sphere, an elongated closed shape rounds up, a patch filled into a
hole blends smoothly into the surrounding surface. ``regularize`` only slides vertices in their
tangent planes to even out triangle sizes and shapes.
"""

from dataclasses import dataclass, field

import numpy as np

from .core import MeshError, _native, as_count, as_faces, as_mask, as_vertices

__all__ = ["FairResult", "fair", "regularize", "willmore_energy", "subdivide_region", "refine_region"]

METHODS = ("willmore", "bilaplacian", "laplacian_of_h")
SCHEMES = ("explicit", "semi_implicit")
BOUNDARIES = ("fixed", "sliding")


@dataclass
class FairResult:
    """Result of :func:`fair`.

    vertices: (n', 3) positions; the input's vertices keep their indices (fixed ones are exactly
        unchanged), new vertices from subdivision follow.
    faces: (m', 3); the same array as the input when nothing was subdivided. Row f < m holds a
        child of input face f (or f itself), the extra children follow.
    face_origin: (m',) input face each output face comes from.
    energy: Willmore energy after each iteration; energy[0] is the input's (of the faired region
        and its first fixed ring in region mode).
    moved: (n',) bool, vertices that were free to move.
    linear_start: the flow started from the linearised minimiser (counted as iteration 1).
    energy_rose: some level's flow ended above the energy it started from (a mesh the flow cannot
        improve: slivers, fan-triangulated caps); that level's lowest-energy state was returned.
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_origin: np.ndarray
    energy: np.ndarray
    moved: np.ndarray
    iterations: int = 0
    level_iterations: list = field(default_factory=list)
    converged: bool = False
    lam: float = 1.0
    linear_start: bool = False
    energy_rose: bool = False

    @property
    def subdivided(self):
        return len(self.faces) != len(self.face_origin) or bool(np.any(self.face_origin != np.arange(len(self.faces))))


def _choice(value, allowed, what):
    v = str(value).lower()
    if v not in allowed:
        raise MeshError(f"{what} must be one of {', '.join(allowed)}; got {value!r}")
    return v


def fair(V, F, *, method="willmore", mask=None, faces=None, boundary="fixed", subdivisions=0,
         tolerance=1e-4, max_iterations=None, tangential=True, scheme="semi_implicit",
         max_seconds=0.0, step_scale=1.0, linear_start=True, refine=False, keep_size=True,
         progress=None):
    """Fair a triangle mesh (or a region of it) by a curvature flow.

    method: "willmore" (thesis eq. 3.5: speed -Lap(H) - 2H(H^2-K) along the normal, plus the
        tangential drift of eq. 3.10), "laplacian_of_h" (eq. 3.12) or "bilaplacian"
        (P <- P - tau U0^2(P)), the thesis's comparison flows.
    mask: vertices allowed to move (bool per vertex, or indices). The fixed vertices next to them
        keep position and tangent plane, so a filled hole blends smoothly (G1) into the surface.
        None: the whole mesh moves (mesh-boundary vertices per ``boundary``).
    faces: faces refined by ``subdivisions`` (bool per face or indices); default: the faces
        touching a movable vertex. Edges shared with faces outside are not split, so the rest of
        the mesh keeps its topology. A hole filled without interior vertices (one n-gon, a fan)
        needs ``faces`` and ``subdivisions >= 1``: the new edge midpoints are the ones that move.
    boundary: "fixed" or "sliding" (boundary vertices slide along the boundary curve).
    subdivisions: coarse-to-fine levels: fair, refine 1-to-4 (linear), fair again (fig. 3.5); each
        refined level first puts its new midpoints at the minimiser of the linearised (cotangent
        bi-Laplacian) energy with the old vertices held, when that lowers the energy (counted as
        an iteration), so it does not spend its iterations on the split's creases.
    tolerance: stop when the relative energy change over a window of flow time falls below it
        (semi-implicit: also when 16 accepted steps found no energy lower by this fraction than
        the lowest before them; ``converged`` is then False if the energy had crept up).
    max_iterations: per level; default 5000 (explicit) or 200 (semi-implicit).
    tangential: add the tangential drift that equalises triangles (eq. 3.8).
    scheme: "semi_implicit" (default: a linearised implicit bi-Laplacian step, same fixed points,
        far larger steps) or "explicit" (the thesis's forward Euler with tau = A_min^2 / 150).
    max_seconds: wall-clock budget (0 = none). step_scale: multiplies the explicit time step.
    linear_start: with fixed vertices (region mode, fixed boundary), "willmore" and
        "laplacian_of_h" first jump to the minimiser of the linearised energy (U0^2 P = 0 with
        the fixed rings as boundary data, the bilaplacian flow's steady state) when that lowers
        the Willmore energy, then flow from there. A flat hole fill has a crease along its rim
        that costs little discrete energy on a coarse mesh, and the flow alone stays near it.
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

    Returns a :class:`FairResult`.
    """
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    method = _choice(method, METHODS, "method")
    scheme = _choice(scheme, SCHEMES, "scheme")
    boundary = _choice(boundary, BOUNDARIES, "boundary")
    vm = as_mask(mask, len(V), "mask")
    fm = as_mask(faces, len(F), "faces")
    if fm is not None and vm is None:
        vm = np.zeros(len(V), dtype=bool)
        inner = np.zeros(len(V), dtype=bool)
        inner[F[fm].ravel()] = True
        # Without a vertex mask, the vertices of the region's faces move except its border.
        border = np.zeros(len(V), dtype=bool)
        border[F[~fm].ravel()] = True
        vm = inner & ~border
    if max_iterations is None:
        max_iterations = 5000 if scheme == "explicit" else 200
    max_iterations = as_count(max_iterations, "max_iterations")
    subdivisions = as_count(subdivisions, "subdivisions", 0, 6)

    def run(Vc, Fc, vmc, fmc, prog):
        r = _native.fair(Vc, Fc, method, scheme, boundary, vmc, fmc, int(subdivisions), float(tolerance),
                         int(max_iterations), float(max_seconds), bool(tangential), float(step_scale), prog,
                         bool(linear_start), bool(refine), bool(keep_size))
        return FairResult(
            vertices=r["vertices"], faces=r["faces"], face_origin=r["face_origin"], energy=r["energy"],
            moved=r["vertex_mask"], iterations=r["iterations"], level_iterations=list(r["level_iterations"]),
            converged=r["converged"], lam=r["lambda"], linear_start=r["linear_start"],
            energy_rose=r.get("energy_rose", False))

    parts = _independent_parts(F, vm, fm, len(V))
    if len(parts) < 2:
        return run(V, F, vm, fm, progress)
    return _fair_parts(V, F, vm, fm, parts, run, progress)


def _independent_parts(F, vm, fm, n):
    """Vertex masks of the parts of a region that do not interact: the movable vertices and the
    region's faces, grouped by the connected components of their two-ring neighbourhoods (the
    flows read two rings around a vertex: H on its ring, the Laplacian of H on the next). One part
    or none: []."""
    if vm is None:
        return []
    region = vm.copy()
    if fm is not None:
        region[F[fm].ravel()] = True
    if not region.any():
        return []
    zone = region
    for _ in range(2):
        zone = zone.copy()
        zone[F[zone[F].any(1)].ravel()] = True
    inside = zone[F].all(1)
    pairs = np.concatenate([F[inside][:, [0, 1]], F[inside][:, [1, 2]], F[inside][:, [2, 0]]])
    pairs = np.ascontiguousarray(pairs, dtype=np.int32)
    labels = np.asarray(_native.connected_labels(int(n), pairs))
    ids = np.unique(labels[region])
    return [region & (labels == i) for i in ids] if len(ids) > 1 else []


def _fair_parts(V, F, vm, fm, parts, run, progress):
    """Fairs independent parts of a region one after the other on the same mesh, so each flow keeps
    its own step size and stopping test (a shared step control let one part's energy drop carry
    another part's rise: two feet of the elephant faired together ended 0.09-0.49 of the diagonal
    from each faired alone). The input's vertices keep their indices and rows of faces outside a
    part are untouched, so each part's masks carry over to the mesh the previous parts left."""
    n0, m0 = len(V), len(F)
    Vc, Fc, origin = V, F, np.arange(m0)
    results = []
    for k, part in enumerate(parts):
        vmc = np.zeros(len(Vc), dtype=bool)
        vmc[:n0] = vm & part
        fmc = None
        if fm is not None:
            fmc = np.zeros(len(Fc), dtype=bool)
            fmc[:m0] = fm & part[F].any(1)
        prog = None if progress is None else (lambda f, k=k: progress((k + f) / len(parts)))
        r = run(Vc, Fc, vmc, fmc, prog)
        Vc, Fc, origin = r.vertices, r.faces, origin[r.face_origin]
        results.append(r)
    length = max(len(r.energy) for r in results)
    energy = sum(np.pad(r.energy, (0, length - len(r.energy)), mode="edge") for r in results)
    moved = np.zeros(len(Vc), dtype=bool)
    for r in results:
        moved[:len(r.moved)] |= r.moved
    levels = max(len(r.level_iterations) for r in results)
    return FairResult(
        vertices=Vc, faces=Fc, face_origin=origin, energy=energy, moved=moved,
        iterations=max(r.iterations for r in results),
        level_iterations=[max((r.level_iterations[i] for r in results if i < len(r.level_iterations)), default=0)
                          for i in range(levels)],
        converged=all(r.converged for r in results), lam=min(r.lam for r in results),
        linear_start=any(r.linear_start for r in results), energy_rose=any(r.energy_rose for r in results))


def regularize(V, F, *, iterations=100, mask=None, boundary="fixed", step_scale=1.0, project=True,
               progress=None):
    """Tangential regularisation (thesis eq. 3.8 with tau = 0, fig. 3.3-3.4): vertices drift in
    their tangent planes by the tangent part of the area-weighted bi-umbrella operator, which
    evens out triangle sizes and shapes while keeping the surface. Returns the new (n, 3)
    positions; vertices outside ``mask`` (bool per vertex or indices) are unchanged.
    ``project`` puts moved vertices back onto the input surface after each step (the drift
    alone leaves a curved surface by O(step^2 * curvature) per step)."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    boundary = _choice(boundary, BOUNDARIES, "boundary")
    vm = as_mask(mask, len(V), "mask")
    iterations = as_count(iterations, "iterations")
    return _native.regularize(V, F, iterations, vm, boundary, float(step_scale), bool(project), progress)


def willmore_energy(V, F):
    """Discrete Willmore energy sum H_i^2 A_i (mixed areas): 4 pi for a sphere, 2 pi^2 for the
    torus with radii ratio sqrt(2)."""
    return _native.willmore_energy(as_vertices(V), as_faces(F))


def subdivide_region(V, F, faces):
    """Linear 1-to-4 subdivision of the faces selected by ``faces`` only; edges shared with other
    faces are not split (the faces along the border become 2 or 3 triangles). Returns
    (V, F, face_origin)."""
    V = as_vertices(V)
    F = as_faces(F, n=len(V))
    fm = as_mask(faces, len(F), "faces")
    if fm is None:
        fm = np.ones(len(F), dtype=bool)
    return _native.subdivide_region(V, F, fm)


def refine_region(V, F, faces, density=2 ** 0.5):
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
    return _native.refine_region(V, F, fm, float(density))
