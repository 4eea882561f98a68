"""dgmesh.fair / dgmesh.regularize: the numpy API over the native Willmore flow."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dgmesh
from dgmesh import shapes
from dgmesh.polymesh.measures import min_angle_deg


def _cap_hole(level=4, z0=0.75):
    """Unit icosphere with the cap above z0 flattened: (V_flat, F, movable mask, cap faces)."""
    V, F = shapes.icosphere(level)
    above = (V[F][:, :, 2] > z0).all(axis=1)
    outside = np.zeros(len(V), dtype=bool)
    outside[F[~above].ravel()] = True
    movable = ~outside & (V[:, 2] > z0)
    W = V.copy()
    W[movable, 2] = z0
    return W, F, movable, above


def test_sphere_energy_and_invariance():
    V, F = shapes.icosphere(3, 2.0)
    assert dgmesh.willmore_energy(V, F) == pytest.approx(4 * np.pi, rel=0.03)
    r = dgmesh.fair(V, F, max_iterations=50)
    rad = np.linalg.norm(r.vertices, axis=1)
    assert np.ptp(rad) / rad.mean() < 2e-3
    assert r.energy[-1] == pytest.approx(r.energy[0], rel=0.01)
    assert r.faces is not None and np.array_equal(r.faces, F)
    assert not r.subdivided


def test_hole_restoration_region_mode():
    W, F, movable, _ = _cap_hole()
    r = dgmesh.fair(W, F, mask=movable)
    assert r.converged
    assert np.array_equal(r.vertices[~movable], W[~movable])  # bit-identical outside
    dev = np.abs(np.linalg.norm(r.vertices[movable], axis=1) - 1)
    assert dev.max() < 2e-3
    rb = dgmesh.fair(W, F, mask=movable, method="bilaplacian")
    devb = np.abs(np.linalg.norm(rb.vertices[movable], axis=1) - 1)
    assert dev.max() < 0.2 * devb.max()
    assert np.all(np.diff(r.energy) <= 1e-4 * r.energy[:-1])


def test_fill_without_interior_vertices_needs_subdivision():
    """A hole filled by a fan (no interior vertex), refined and faired: the user's workflow of
    delete -> fill -> fair."""
    V, F = shapes.icosphere(3)
    c = int(np.argmax(V[:, 2]))
    star = (F == c).any(axis=1)
    nxt = {}
    for f in F[star]:
        k = list(f).index(c)
        nxt[f[(k + 1) % 3]] = f[(k + 2) % 3]
    ring = [next(iter(nxt))]
    while len(ring) < len(nxt):
        ring.append(nxt[ring[-1]])
    fan = np.array([[ring[0], ring[i], ring[i + 1]] for i in range(1, len(ring) - 1)], dtype=np.int32)
    F2 = np.concatenate([F[~star], fan])
    region = np.zeros(len(F2), bool)
    region[-len(fan):] = True
    with pytest.raises(dgmesh.MeshError, match="nothing to fair"):
        dgmesh.fair(V, F2, mask=np.zeros(len(V), bool))
    from dgmesh.fairing import subdivide_region

    flat = subdivide_region(V, F2, region)[0][len(V):]
    r = dgmesh.fair(V, F2, faces=region, subdivisions=3)
    assert r.subdivided and len(r.faces) > len(F2)
    new = np.arange(len(V), len(r.vertices))
    dev = np.abs(np.linalg.norm(r.vertices[new], axis=1) - 1)
    dev_flat = np.abs(np.linalg.norm(flat, axis=1) - 1)
    assert dev.max() < 0.2 * dev_flat.max()
    # Faces outside the refined region keep their rows; the rest of the mesh is untouched.
    assert np.array_equal(r.faces[:len(F2)][~region], F2[~region])
    assert np.array_equal(r.face_origin[:len(F2)], np.arange(len(F2)))
    assert np.array_equal(r.vertices[:len(V)], V)
    dgmesh.validate(r.vertices, r.faces)


def _fan_filled_cap(z0=0.7):
    """Unit icosphere(4) with the cap above z0 removed and its rim filled by a fan (Blender's Fill:
    no inner vertex). Returns (V, F, fill face mask, rim loop)."""
    V, F = shapes.icosphere(4)
    cap = (V[F][:, :, 2] > z0).all(axis=1)
    loop = dgmesh.topology(V, F[~cap]).boundary_loops[0]
    fan = np.array([[loop[0], loop[i + 1], loop[i]] for i in range(1, len(loop) - 1)], dtype=np.int32)
    F2 = np.concatenate([F[~cap], fan])
    region = np.zeros(len(F2), dtype=bool)
    region[len(F2) - len(fan):] = True
    return V, F2, region, np.asarray(loop)


def _edge_lengths(V, F):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)


def test_refine_region_sizes_a_coarse_fill_like_the_rim():
    from dgmesh.fairing import refine_region

    V, F, region, loop = _fan_filled_cap()
    rim = np.linalg.norm(V[loop] - V[np.roll(loop, -1)], axis=1).mean()
    assert _edge_lengths(V, F[region]).max() > 5 * rim  # the fan's long edges
    Vr, Fr, origin = refine_region(V, F, region)
    reg = region[origin]
    assert len(Vr) > len(V) + 100
    assert np.array_equal(Vr[:len(V)], V)
    assert np.array_equal(Fr[:len(F)][~region], F[~region])  # outside: same rows
    lengths = _edge_lengths(Vr, Fr[reg])
    assert lengths.mean() == pytest.approx(rim, rel=0.3)
    assert lengths.max() < 2.5 * rim
    assert dgmesh.topology(Vr, Fr).boundary_loops == []  # closed again, manifold
    with pytest.raises(dgmesh.MeshError, match="faces must be"):
        refine_region(V, F, region[:-1])
    with pytest.raises(dgmesh.MeshError, match="density"):
        refine_region(V, F, region, density=0)


def test_fair_refine_restores_a_fan_filled_hole():
    """Delete -> Fill -> Fair(refine): the fan is refined to rim-sized triangles and faired back to
    the sphere; the rest of the mesh is untouched."""
    V, F, region, _ = _fan_filled_cap()
    r = dgmesh.fair(V, F, faces=region, refine=True)
    assert r.subdivided
    new = np.arange(len(V), len(r.vertices))
    assert len(new) > 100 and r.moved[new].all() and not r.moved[:len(V)].any()
    assert np.array_equal(r.vertices[:len(V)], V)
    assert np.array_equal(r.faces[:len(F)][~region], F[~region])
    dev = np.abs(np.linalg.norm(r.vertices[new], axis=1) - 1)
    assert dev.max() < 0.01  # the flat fan is ~0.27 off
    rb = dgmesh.fair(V, F, faces=region, refine=True, method="bilaplacian")
    devb = np.abs(np.linalg.norm(rb.vertices[new], axis=1) - 1)
    assert dev.max() < 0.2 * devb.max()
    dgmesh.validate(r.vertices, r.faces)


@pytest.mark.parametrize("method", ["willmore", "bilaplacian", "laplacian_of_h", "hinge"])
@pytest.mark.parametrize("scheme", ["explicit", "semi_implicit"])
def test_methods_and_schemes_lower_the_energy(method, scheme):
    W, F, movable, _ = _cap_hole(level=3, z0=0.6)
    r = dgmesh.fair(W, F, mask=movable, method=method, scheme=scheme, max_iterations=300, step_scale=4)
    assert r.energy[-1] < r.energy[0]
    assert np.isfinite(r.vertices).all()


def test_boundary_modes():
    V, F = shapes.grid(10, 10)
    V[:, 2] = 0.2 * np.sin(3 * V[:, 0]) * np.sin(3 * V[:, 1])
    loops = dgmesh.topology(V, F).boundary_loops
    b = np.unique(np.concatenate(loops))
    fixed = dgmesh.fair(V, F, max_iterations=30)
    assert np.array_equal(fixed.vertices[b], V[b])
    sliding = dgmesh.fair(V, F, boundary="sliding", max_iterations=30)
    x, y = sliding.vertices[b, 0], sliding.vertices[b, 1]
    side = np.minimum.reduce([np.abs(x), np.abs(1 - x), np.abs(y), np.abs(1 - y)])
    assert side.max() < 1e-9
    assert not np.array_equal(sliding.vertices[b], V[b])


def test_regularize_improves_min_angle_and_stays_on_surface():
    V, F = shapes.grid(12, 12)
    rng = np.random.default_rng(1)
    inner = (V[:, 0] > 0) & (V[:, 0] < 1) & (V[:, 1] > 0) & (V[:, 1] < 1)
    Vj = V.copy()
    Vj[inner, :2] += rng.uniform(-0.03, 0.03, (inner.sum(), 2))
    Vj[:, 2] = 0.3 * Vj[:, 0] ** 2  # a curved (parabolic) surface
    def min_angle(X):
        P = X[F]
        a = []
        for k in range(3):
            u = P[:, (k + 1) % 3] - P[:, k]
            w = P[:, (k + 2) % 3] - P[:, k]
            c = (u * w).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
            a.append(np.degrees(np.arccos(np.clip(c, -1, 1))))
        return np.min(a)
    R = dgmesh.regularize(Vj, F, iterations=200)
    assert min_angle(R) > min_angle(Vj) + 3
    # On the surface: z = 0.3 x^2 up to the chord error of the input's triangles.
    assert np.abs(R[:, 2] - 0.3 * R[:, 0] ** 2).max() < 2e-3
    assert np.array_equal(R[~inner], Vj[~inner])
    # mask: only those move
    m = np.zeros(len(V), bool)
    m[np.flatnonzero(inner)[:10]] = True
    Rm = dgmesh.regularize(Vj, F, iterations=20, mask=m)
    assert np.array_equal(Rm[~m], Vj[~m])


def test_bad_input():
    V, F = shapes.icosphere(1)
    with pytest.raises(dgmesh.MeshError, match="method"):
        dgmesh.fair(V, F, method="nope")
    with pytest.raises(dgmesh.MeshError, match="boundary"):
        dgmesh.fair(V, F, boundary="nope")
    with pytest.raises(dgmesh.MeshError, match="mask"):
        dgmesh.fair(V, F, mask=np.ones(3, bool))
    with pytest.raises(dgmesh.MeshError):
        dgmesh.fair(V, F, subdivisions=-1)
    bad = V.copy()
    bad[0, 0] = np.nan
    with pytest.raises(dgmesh.MeshError):
        dgmesh.fair(bad, F)
    with pytest.raises(dgmesh.MeshError):
        dgmesh.regularize(V, F[:, :2])
    Vc = V.copy()
    dgmesh.fair(Vc, F, max_iterations=3)
    assert np.array_equal(Vc, V)  # input untouched


def test_progress_and_cancel():
    V, F = shapes.icosphere(2)
    seen = []
    dgmesh.fair(V, F, max_iterations=20, progress=lambda f: seen.append(f))
    assert seen and seen[0] == 0.0 and seen[-1] == 1.0
    with pytest.raises(dgmesh.Cancelled):
        dgmesh.fair(V, F, progress=lambda f: f < 0.0001 and f == 0.0)


@pytest.mark.parametrize("linear_start", [True, False])
def test_hole_in_a_sphere_willmore_restores_the_sphere_closer_than_bilaplacian(linear_start):
    # Known answer: with position and tangent plane fixed by the two rings around the hole, the
    # Willmore minimiser is the spherical cap; the bi-umbrella one is not a sphere.
    W, F, movable, _ = _cap_hole(level=3, z0=0.3)
    dev = lambda V: np.abs(np.linalg.norm(V[movable], axis=1) - 1.0)  # noqa: E731
    assert dev(W).max() > 0.3  # the flat fill is far off
    w = dgmesh.fair(W, F, mask=movable, method="willmore", linear_start=linear_start)
    b = dgmesh.fair(W, F, mask=movable, method="bilaplacian")
    assert w.converged and w.linear_start == linear_start
    assert dev(w.vertices).max() < 0.01, dev(w.vertices).max()
    assert dev(b.vertices).mean() > 5 * dev(w.vertices).mean()
    # Monotone energy, the linear start included (it is only taken when it lowers the energy).
    assert len(w.energy) == w.iterations + 1
    assert np.all(np.diff(w.energy) <= 1e-4 * w.energy[:-1])
    assert np.array_equal(w.vertices[~movable], W[~movable])


def test_an_exhausted_budget_is_not_reported_as_convergence():
    W, F, movable, _ = _cap_hole(level=3, z0=0.3)
    r = dgmesh.fair(W, F, mask=movable, method="willmore", scheme="explicit", max_iterations=20, linear_start=False)
    assert not r.converged and r.iterations == 20


def test_a_level_stops_when_its_energy_stops_falling():
    # Blender's torus (48 x 12, tube radius 1/4) with one subdivision: the subdivided level's step
    # control cycles below the long steps the convergence test asks for, and it used to run its
    # whole budget at a relative energy change of 2e-6 per step (5 s instead of 0.7 s).
    V, F = shapes.torus(1.0, 0.25, 48, 12)
    r = dgmesh.fair(V, F, subdivisions=1, max_iterations=300)
    assert r.level_iterations[1] < 100 and r.converged
    assert r.energy[-1] == pytest.approx(2 * np.pi ** 2, rel=0.03)  # the Clifford torus


ROOT = Path(__file__).resolve().parents[2]


def _cgal_mesh(name):
    """A model of Debian's CGAL data (unpacked by scripts/cgal_data.sh), or skip."""
    out = subprocess.run(["bash", str(ROOT / "scripts" / "cgal_data.sh")], capture_output=True, text=True)
    path = Path(out.stdout.strip().splitlines()[-1]) / name if out.returncode == 0 and out.stdout.strip() else None
    if path is None or not path.exists():
        pytest.skip("CGAL data not available (bash scripts/cgal_data.sh)")
    return dgmesh.read_mesh(path)


def _bunny_fan_hole():
    """Bunny (CGAL data) with a 10% geodesic disk around vertex 32073 removed and the hole filled
    by a fan over its rim (Blender's Fill): the benchmark's bunny00 10% seed-0 hole."""
    V, F = _cgal_mesh("bunny00.off")
    sys.path.insert(0, str(ROOT))
    from bench.workloads.fair import cut_hole, fan_fill

    hole, inner = cut_hole(V, F, 32073, 0.10)
    F2, fill = fan_fill(V, F, hole, inner)
    return V, F, hole, F2, fill


def test_refined_fan_fill_has_no_valence3_vertices():
    """Centroid splits the flips cannot dissolve (next to the rim) are merged back: their
    degenerate umbrella put them on spikes in the linear start."""
    from dgmesh.fairing import refine_region

    V, _F, _hole, F2, fill = _bunny_fan_hole()
    Vr, Fr, origin = refine_region(V, F2, fill)
    region = fill[origin]
    valence = np.bincount(Fr[region].ravel(), minlength=len(Vr))
    assert len(Vr) > len(V) + 500
    assert valence[len(V):].min() >= 4
    assert np.array_equal(Fr[: len(F2)][~fill], F2[~fill])  # rows outside the fill untouched
    used = np.zeros(len(Vr), dtype=bool)
    used[Fr.ravel()] = True
    assert used[len(V):].all()  # removed vertices are compacted away


def test_willmore_descends_after_the_linear_start_on_a_refined_fan_fill():
    """The fan-plus-refine stall: the flow used to stop at the linear start (Willmore == the
    bilaplacian result) because one spike vertex capped every step. It must now descend well
    below the linear start and restore the bunny closer than the bilaplacian flow."""
    V, F, hole, F2, fill = _bunny_fan_hole()
    w = dgmesh.fair(V, F2, faces=fill, refine=True, method="willmore")
    b = dgmesh.fair(V, F2, faces=fill, refine=True, method="bilaplacian")
    assert w.linear_start
    assert w.energy[-1] < 0.75 * w.energy[1], (w.energy[1], w.energy[-1])
    assert np.all(np.diff(w.energy) <= 1e-4 * w.energy[:-1])
    # Mean distance of the removed original vertices (~3900, denser than the fill) to the
    # restored fill.
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from bench.workloads.fair import point_surface_distance

    orig = V[np.setdiff1d(np.unique(F[hole]), np.unique(F[~hole]))]

    def dist(r):
        return point_surface_distance(orig, r.vertices, r.faces[fill[r.face_origin]]).mean()

    dw, db = dist(w), dist(b)
    assert dw < 0.6 * db, (dw, db)  # 0.38 measured; equal before the fix


def test_refine_region_retriangulates_a_fill_by_min_weight():
    """A fill without inner vertices is first re-triangulated by Liepa's minimum-weight
    triangulation of its loop (smallest largest dihedral angle, then area): two fans over the same
    hole, from different apexes, refine to the same mesh, and the refined fill does not keep a
    fan's folds across a non-planar rim."""
    from dgmesh.fairing import refine_region

    V, F, hole, F2, fill = _bunny_fan_hole()
    k = len(F2) - int(fill.sum())
    fan = F2[k:]  # rows (l[0], l[i + 1], l[i]) for i = 1 .. n - 2
    loop = [int(fan[0, 0])] + [int(v) for v in fan[:, 2]] + [int(fan[-1, 1])]
    assert len(set(loop)) == len(loop) == len(fan) + 2
    shift = len(loop) // 3
    other = np.roll(loop, -shift)
    fan2 = np.array([[other[0], other[i + 1], other[i]] for i in range(1, len(other) - 1)], dtype=F2.dtype)
    F3 = np.concatenate([F2[:k], fan2])
    a, b = refine_region(V, F2, fill), refine_region(V, F3, fill)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])

    def max_dihedral(Vx, Fx, region):
        N = np.cross(Vx[Fx[:, 1]] - Vx[Fx[:, 0]], Vx[Fx[:, 2]] - Vx[Fx[:, 0]])
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        E = np.concatenate([np.sort(Fx[:, [0, 1]], 1), np.sort(Fx[:, [1, 2]], 1), np.sort(Fx[:, [2, 0]], 1)])
        f = np.tile(np.arange(len(Fx)), 3)
        order = np.lexsort(E.T[::-1])
        E, f = E[order], f[order]
        same = np.all(E[1:] == E[:-1], axis=1)
        f0, f1 = f[:-1][same], f[1:][same]
        keep = region[f0] | region[f1]
        return np.degrees(np.arccos(np.clip((N[f0[keep]] * N[f1[keep]]).sum(1), -1, 1))).max()

    # Without splits (a huge target length) the fill keeps n - 2 triangles; its folds are gone.
    Vn, Fn, on = refine_region(V, F2, fill, density=1e-9)
    assert len(Vn) == len(V)
    assert max_dihedral(V, F2, fill) > 170 and max_dihedral(Vn, Fn, fill[on]) < 120


def test_a_flow_that_raises_the_energy_keeps_its_lowest_state():
    """The bi-umbrella flow of a closed mesh without fixed vertices shrinks it towards a point (its
    bending energy rising without bound): the level returns its lowest-energy state and says so."""
    V, F = shapes.icosphere(3)
    V = V * np.array([2.0, 1.0, 1.0])
    r = dgmesh.fair(V, F, method="bilaplacian", max_iterations=50)
    assert r.energy_rose
    assert r.energy[-1] <= r.energy[0] * (1 + 1e-9)
    assert np.ptp(r.vertices, axis=0).min() > 0.5 * np.ptp(V, axis=0).min()
    # The Willmore flow of the same ellipsoid lowers its energy: no such fallback.
    assert not dgmesh.fair(V, F).energy_rose


def test_a_closed_part_beside_an_open_one_keeps_its_lowest_bilaplacian_state():
    """One mesh with a closed part (an ellipsoid) and an open one (a wavy grid, boundary fixed): the
    bilaplacian flow shrinks the closed part towards a point while the open part's energy falls, so
    the total hid the collapse (the ellipsoid went from extent 2 to 6e-5). Each closed part keeps
    its own lowest-energy state; the open part still reaches its steady state."""
    Vs, Fs = shapes.icosphere(3)
    Vs = Vs * np.array([2.0, 1.0, 1.0])
    Vg, Fg = shapes.grid(10, 10)
    Vg = Vg * 4 + np.array([5.0, 0.0, 0.0])
    Vg[:, 2] = 0.3 * np.sin(3 * Vg[:, 0]) * np.cos(2 * Vg[:, 1])
    V = np.concatenate([Vs, Vg])
    F = np.concatenate([Fs, Fg + len(Vs)])
    r = dgmesh.fair(V, F, method="bilaplacian", max_iterations=50)
    assert r.energy_rose
    W = r.vertices
    assert np.ptp(W[:len(Vs)], axis=0).min() > 0.5 * np.ptp(Vs, axis=0).min()
    inner = ((Vg[:, :2] > Vg[:, :2].min(0) + 1e-9) & (Vg[:, :2] < Vg[:, :2].max(0) - 1e-9)).all(1)
    assert np.abs(W[len(Vs):][inner] - Vg[inner]).max() > 0.05  # the grid was faired


def test_the_bilaplacian_flow_with_fixed_vertices_reaches_its_steady_state():
    """The lowest-energy fallback is for a closed mesh collapsing, not for a region: a torus band
    between fixed parts narrows into the bi-umbrella flow's steady state (a neck), whose Willmore
    energy is above the start's. (It had returned the input unchanged; on the benchmark's protrusion
    holes the bilaplacian patch stayed at the fill, twice as far from the removed surface.)"""
    V, F = shapes.torus(3.0, 1.0, 48, 24)
    u = np.arctan2(V[:, 1], V[:, 0])
    band = np.abs(u) < 0.6
    r = dgmesh.fair(V, F, method="bilaplacian", mask=band, max_iterations=200)
    assert not r.energy_rose and r.converged
    axis = np.stack([3 * np.cos(u), 3 * np.sin(u), 0 * u], 1)
    assert np.linalg.norm(r.vertices - axis, axis=1)[band].min() < 0.85
    assert r.energy[-1] > r.energy[0]


def _area_and_centroid(V, F):
    a = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    return a.sum(), (a[:, None] * V[F].mean(axis=1)).sum(axis=0) / a.sum()


def test_a_closed_object_faired_whole_keeps_its_place_and_size():
    # eight.off (genus 2, no symmetry the flow keeps): the discrete speed has a small net force,
    # which the semi-implicit steps turned into a drift of 6 bbox diagonals in 200 steps, and the
    # flow shrank it to 0.59 of its area; its energy is invariant under similarities either way.
    V, F = _cgal_mesh("eight.off")
    diag = np.linalg.norm(V.max(0) - V.min(0))
    a0, c0 = _area_and_centroid(V, F)
    r = dgmesh.fair(V, F, max_iterations=100)
    a1, c1 = _area_and_centroid(r.vertices, F)
    assert r.energy[-1] < 0.6 * r.energy[0]
    assert a1 == pytest.approx(a0, rel=1e-9)
    assert np.linalg.norm(c1 - c0) < 1e-9 * diag
    # The Laplacian-of-H flow is scale-equivariant too (it shrank the ellipsoid of the Blender tests
    # to 77% of its area).
    r3 = dgmesh.fair(V, F, method="laplacian_of_h", max_iterations=30)
    assert _area_and_centroid(r3.vertices, F)[0] == pytest.approx(a0, rel=1e-9)
    # Without keep_size the size changes, but the object still does not drift away.
    r2 = dgmesh.fair(V, F, max_iterations=100, keep_size=False)
    a2, c2 = _area_and_centroid(r2.vertices, F)
    assert abs(a2 / a0 - 1) > 0.05
    assert np.linalg.norm(c2 - c0) < 0.05 * diag
    assert r2.energy[-1] == pytest.approx(r.energy[-1], rel=0.05)


def test_separate_patches_are_faired_as_if_each_were_alone():
    """Two patches that do not interact: faired together, each ends where it ends alone (a shared
    step control let one's energy drop carry the other's rise: an elephant's foot ballooned)."""
    V, F = shapes.icosphere(4)
    V = V * np.array([1.0, 1.0, 1.6])  # an ellipsoid: the patches are not already minimal
    patches = []
    for c in (np.array([0, 0, 1.6]), np.array([1.0, 0, 0])):
        near = np.linalg.norm(V - c, axis=1) < 0.35
        patches.append(near)
    both = dgmesh.fair(V, F, mask=patches[0] | patches[1])
    energy = 0.0
    for m in patches:
        alone = dgmesh.fair(V, F, mask=m)
        np.testing.assert_array_equal(both.vertices[m], alone.vertices[m])
        energy += alone.energy[-1]
    assert both.energy[-1] == pytest.approx(energy)
    # With subdivision, each patch's faces are refined and faired as alone too.
    fm = [m[F].all(1) for m in patches]
    both = dgmesh.fair(V, F, faces=fm[0] | fm[1], subdivisions=1)
    assert len(both.faces) == len(F) + sum(len(dgmesh.fair(V, F, faces=f, subdivisions=1).faces) - len(F) for f in fm)
    assert (both.face_origin < len(F)).all()


def test_patches_whose_bands_touch_at_a_vertex_are_faired():
    """The flow works on the faces within two rings of the movable vertices. Two bumps four cells
    apart diagonally: their bands touch at one vertex, where that working mesh is a bow tie. Refused
    before as "not manifold" (bench fair_repair: 18 of 135 regions on the CGAL scans); that vertex is
    fixed and only completes its neighbours' rings, so it is split per fan. Each bump ends as it
    ends alone; the vertex between them is untouched."""
    V, F = shapes.grid(13, 8)
    V = V * np.array([13.0, 8.0, 1.0])  # unit cells
    V[:, 2] = 0.05 * np.sin(V[:, 0]) * np.cos(V[:, 1])
    row = {(int(round(x)), int(round(y))): k for k, (x, y, _) in enumerate(V)}

    def idx(i, j):
        return row[(i, j)]
    bumps = [idx(6, 2), idx(10, 6)]  # four cells apart diagonally: the bands touch at one vertex
    W = V.copy()
    W[bumps, 2] += 0.5
    mask = np.zeros(len(V), bool)
    mask[bumps] = True
    both = dgmesh.fair(W, F, mask=mask)
    for b in bumps:
        alone = np.zeros(len(V), bool)
        alone[b] = True
        np.testing.assert_allclose(both.vertices[b], dgmesh.fair(W, F, mask=alone).vertices[b], atol=1e-9)
        assert abs(both.vertices[b, 2] - V[b, 2]) < 0.5 * 0.5  # the bump went down
    np.testing.assert_array_equal(both.vertices[~mask], W[~mask])
    np.testing.assert_array_equal(both.faces, F)
    # A non-manifold vertex of the input itself, next to the movable vertices, is still refused: two
    # of the faces around it removed, not side by side, leave it two fans.
    pinch = idx(5, 4)
    around = np.flatnonzero((F == pinch).any(1))
    ring = F[around]
    apart = [k for k in range(len(ring)) if len(set(ring[k]) & set(ring[0])) == 1]  # sharing no edge
    G = np.delete(F, around[[0, apart[0]]], axis=0)
    near = np.zeros(len(V), bool)
    near[idx(4, 4)] = True
    with pytest.raises(dgmesh.MeshError, match="region being faired.*not manifold"):
        dgmesh.fair(W, G, mask=near)


def test_regularize_is_not_frozen_by_one_sliver_elsewhere():
    """The drift's step follows the smallest triangle near each vertex (within its two rings), not
    the smallest of the whole mesh: one sliver froze the rest of a scan (camel)."""
    rng = np.random.default_rng(3)
    V, F = shapes.grid(30, 30)
    V = V.copy()
    inner = (V[:, 0] > 1e-9) & (V[:, 0] < 1 - 1e-9) & (V[:, 1] > 1e-9) & (V[:, 1] < 1 - 1e-9)
    V[inner, :2] += rng.uniform(-0.3, 0.3, (inner.sum(), 2)) / 30  # irregular triangles
    v = int(np.flatnonzero(inner)[0])
    w = F[(F == v).any(1)][0]
    w = int(w[w != v][0])
    V[v, :2] = V[w, :2] + 1e-4 * (V[v, :2] - V[w, :2])  # a sliver's tip next to its neighbour

    def min_angles(P):
        T = P[F]
        out = []
        for i in range(3):
            a, b = T[:, (i + 1) % 3] - T[:, i], T[:, (i + 2) % 3] - T[:, i]
            out.append(np.degrees(np.arccos(np.clip((a * b).sum(1) / np.linalg.norm(a, axis=1)
                                                    / np.linalg.norm(b, axis=1), -1, 1))))
        return np.min(out, 0)

    far = ~np.isin(F, [v, w]).any(1)
    before = min_angles(V)[far].mean()
    after = min_angles(dgmesh.regularize(V, F, iterations=50))[far].mean()
    assert after > before + 2.0, (before, after)


@pytest.mark.parametrize("kw", [{"refine": True, "subdivisions": 1}, {"subdivisions": 1}])
def test_refined_or_subdivided_result_does_not_depend_on_the_face_order(kw):
    """Blender hands the same fill's triangles in another row order from one Edit-mode run to the
    next; refining and subdividing made and flipped faces in row order, so one fill gave 578, 598 or
    610 vertices. The result is the same surface whatever the order (rows put back in place)."""
    V, _F, _hole, F2, fill = _bunny_fan_hole()
    r0 = dgmesh.fair(V, F2, faces=fill, max_iterations=3, **kw)
    perm = np.random.default_rng(1).permutation(len(F2))
    r1 = dgmesh.fair(V, F2[perm], faces=fill[perm], max_iterations=3, **kw)
    assert len(r1.vertices) == len(r0.vertices)
    np.testing.assert_allclose(r1.vertices, r0.vertices, atol=1e-9 * np.ptp(V))
    np.testing.assert_array_equal(r1.faces[: len(F2)], r0.faces[: len(F2)][perm])  # input rows in place
    key = lambda F: sorted(map(tuple, np.sort(F, axis=1).tolist()))  # noqa: E731
    assert key(r1.faces) == key(r0.faces)


def test_willmore_energy_does_not_depend_on_the_thread_count():
    # Above 65536 vertices the energy was an OpenMP reduction: its last bits followed the thread
    # count (and, with 3 or more threads, the order the threads finished), and so could the flow's
    # stopping test.
    V, F = shapes.icosphere(7)
    V = V * np.array([1.0, 1.3, 0.8])
    before = dgmesh.num_threads()
    try:
        energies = []
        for n in (1, 2, 3):
            dgmesh.set_num_threads(n)
            energies.append(dgmesh.willmore_energy(V, F))
    finally:
        dgmesh.set_num_threads(before)
    assert len(V) > 65536 and energies[1] == energies[0] and energies[2] == energies[0]


def _flattened_tip(V, F, fraction=0.06):
    """Issue 30's damage as bench/workloads/fair.py's fair_stall makes it: the `fraction` of the
    vertices geodesically nearest to the vertex farthest from the centroid, projected onto the
    least-squares plane of their rim. Returns (W, patch)."""
    sys.path.insert(0, str(ROOT))
    from bench.workloads.fair import damage, region_centre, vertex_ball
    patch = vertex_ball(V, F, region_centre(V, F, "tip"), int(fraction * len(V)))
    return damage(V, F, patch, "flat"), patch


def test_a_region_the_flow_cannot_change_says_so():
    """Never a silent no-op (issue 30): a flat region (energy 0, a minimum) is left as it is and the
    result says that nothing moved; a whole sphere moves but its energy cannot go down."""
    x = np.linspace(-1, 1, 9)
    X, Y = np.meshgrid(x, x)
    V = np.c_[X.ravel(), Y.ravel(), np.zeros(81)]
    idx = np.arange(81).reshape(9, 9)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    F = np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    inner = (np.abs(X.ravel()) < 0.6) & (np.abs(Y.ravel()) < 0.6)
    for method in ("willmore", "bilaplacian", "laplacian_of_h"):
        r = dgmesh.fair(V, F, mask=inner, method=method)
        assert r.stall == dgmesh.FairStall.no_descent and r.stall.name == "no_descent", method
        assert np.abs(r.vertices - V).max() < 1e-12
    Vs, Fs = shapes.icosphere(3)
    assert dgmesh.fair(Vs, Fs, max_iterations=20).stall.name in ("no_change", "no_descent")
    W, F2, movable, _ = _cap_hole()
    r = dgmesh.fair(W, F2, mask=movable)
    assert r.stall.name == "none" and not r.restarted


def test_a_flattened_scan_tip_is_restored_not_left_flat():
    """Issue 30: 6% of elephant.off around its tip flattened onto the rim's plane is a discrete
    minimum: the thesis's flow from it (linear_start off) moves nothing, and says so (no_descent).
    By default the linear start is declined (it raises the energy), the flow from the input stalls,
    and the level is restarted from the linear start: the region moves towards the original."""
    V, F = _cgal_mesh("elephant.off")
    W, patch = _flattened_tip(V, F)
    r0 = dgmesh.fair(W, F, mask=patch, method="willmore", linear_start=False)
    assert r0.stall.name == "no_descent" and not r0.restarted
    assert np.abs(r0.vertices - W).max() < 1e-9 * np.ptp(V)
    r = dgmesh.fair(W, F, mask=patch, method="willmore")
    assert r.restarted and r.linear_start and r.stall.name == "none"
    from bench.workloads.fair import patch_distances  # Metro-style mean distance, both ways
    region = patch[F].any(axis=1)
    flat = patch_distances(V, F, region, W, F, region)[0]
    got = patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0]
    assert got < 0.7 * flat, (got, flat)


def test_a_dented_sphere_cap_restores_to_the_sphere():
    """Known answer: a smooth dent (a bump 0.2 deep pushed into the cap above z = 0.6 of the unit
    icosphere) is faired back to the sphere (a Willmore surface) by the default flow."""
    V, F = shapes.icosphere(4)
    patch = V[:, 2] > 0.6
    rho = np.hypot(V[:, 0], V[:, 1]) / 0.8
    W = V.copy()
    W[patch] *= (1 - 0.2 * np.clip(1 - rho[patch] ** 2, 0, 1) ** 2)[:, None]
    dent = np.abs(np.linalg.norm(W[patch], axis=1) - 1).max()
    r = dgmesh.fair(W, F, mask=patch, method="willmore")
    dev = np.abs(np.linalg.norm(r.vertices[patch], axis=1) - 1)
    assert dent > 0.15 and dev.max() < 3e-3, (dent, dev.max())
    assert r.stall.name == "none"


def _catenoid(n=41):
    """A catenoid strip (a minimal surface, so a Willmore surface: H = 0) over u in [-1.2, 1.2]
    (angle), v in [-0.8, 0.8] (height): (V, F, u, v)."""
    V, F = shapes.grid(n, n)
    u = -1.2 + 2.4 * (V[:, 0] - V[:, 0].min()) / np.ptp(V[:, 0])
    v = -0.8 + 1.6 * (V[:, 1] - V[:, 1].min()) / np.ptp(V[:, 1])
    return np.c_[np.cosh(v) * np.cos(u), np.cosh(v) * np.sin(u), v], F, u, v


def _flattened_catenoid():
    """The catenoid strip with a disk (about 8% of it) projected onto its rim's plane: (W, F, patch)."""
    V, F, u, v = _catenoid()
    patch = np.hypot(u / 1.2, v / 0.8) < 0.3
    rim = np.zeros(len(V), dtype=bool)
    rim[F[patch[F].any(axis=1)].ravel()] = True
    rim &= ~patch
    c = V[rim].mean(0)
    nrm = np.linalg.svd(V[rim] - c)[2][2]
    W = V.copy()
    W[patch] -= np.outer((V[patch] - c) @ nrm, nrm)
    return W, F, patch


def _catenoid_residual(P):
    """Distance-like residual from the catenoid sqrt(x^2 + y^2) = cosh(z)."""
    return np.abs(np.hypot(P[:, 0], P[:, 1]) - np.cosh(P[:, 2]))


@pytest.mark.parametrize("linear_start", [True, False])
def test_a_flattened_patch_of_a_catenoid_restores_to_it(linear_start):
    """Known answer: a disk of a catenoid (about 8% of the strip) flattened onto its rim's plane is
    faired back to the catenoid (H = 0 is a Willmore surface), with and without the linear start."""
    W, F, patch = _flattened_catenoid()
    r = dgmesh.fair(W, F, mask=patch, method="willmore", linear_start=linear_start)
    flat, got = _catenoid_residual(W[patch]).max(), _catenoid_residual(r.vertices[patch]).max()
    assert flat > 0.03 and got < 1e-3 * flat, (flat, got)


def _jittered_ellipsoid(seed, amp=0.15):
    """A 2:1:1 ellipsoid (icosphere level 3) whose vertices are moved in their tangent planes by
    Gaussian offsets of `amp` mean edge lengths: the same surface, uneven triangles."""
    V, F = shapes.icosphere(3)
    V = V * np.array([2.0, 1.0, 1.0])
    h = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
    N = dgmesh.curvature(V, F).normals
    J = np.random.default_rng(seed).normal(0, amp * h, V.shape)
    J -= (J * N).sum(1)[:, None] * N
    return V + J, F


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tangential_drift_keeps_triangles_even_while_an_ellipsoid_rounds_up(seed):
    """Thesis eq. 3.8 / 3.10: with the tangential drift the jittered ellipsoid flows to the round
    sphere (discrete energy 12.51 at this resolution, 4 pi = 12.57) with its smallest angle above 30
    degrees; without it the triangles stay uneven (smallest angle 2.5-9 degrees measured) and on
    seeds 0 and 2 the energy stops higher (14.6, 12.8)."""
    V, F = _jittered_ellipsoid(seed)
    w = dgmesh.fair(V, F, tangential=True)
    wo = dgmesh.fair(V, F, tangential=False)
    assert w.energy[-1] < 12.6 and min_angle_deg(w.vertices, w.faces) > 30
    assert min_angle_deg(wo.vertices, wo.faces) < 15
    assert w.energy[-1] <= wo.energy[-1] + 0.05


def test_the_hinge_energy_restores_sphere_caps_the_bilaplacian_flow_does_not():
    """Issue 30, known answers: a flattened cap (above z = 0.3 of icosphere(3)) and a smooth dent (0.2
    deep, above z = 0.6 of icosphere(4)) are restored to the unit sphere by method="hinge" (the hinge
    energy from the bilaplacian start); the bilaplacian flow's steady state is no sphere. Measured:
    flattened cap 1.0e-3 (bilaplacian 0.133), dent 4.9e-4 (bilaplacian 0.046)."""
    W, F, movable, _ = _cap_hole(level=3, z0=0.3)
    dev = lambda V, m: np.abs(np.linalg.norm(V[m], axis=1) - 1.0)  # noqa: E731
    r = dgmesh.fair(W, F, mask=movable, method="hinge")
    b = dgmesh.fair(W, F, mask=movable, method="bilaplacian")
    assert dev(W, movable).max() > 0.3
    assert dev(r.vertices, movable).max() < 3e-3 and dev(b.vertices, movable).max() > 0.1
    assert r.linear_start and r.converged and r.stall.name == "none"
    assert len(r.energy) == r.iterations + 1 and np.all(np.diff(r.energy[1:]) < 0)
    assert np.array_equal(r.vertices[~movable], W[~movable])

    V, F = shapes.icosphere(4)
    patch = V[:, 2] > 0.6
    rho = np.hypot(V[:, 0], V[:, 1]) / 0.8
    D = V.copy()
    D[patch] *= (1 - 0.2 * np.clip(1 - rho[patch] ** 2, 0, 1) ** 2)[:, None]
    r = dgmesh.fair(D, F, mask=patch, method="hinge")
    b = dgmesh.fair(D, F, mask=patch, method="bilaplacian")
    assert dev(r.vertices, patch).max() < 2e-3 and dev(b.vertices, patch).max() > 0.03


def test_the_hinge_energy_restores_a_flattened_catenoid_patch():
    """Known answer (H = 0): the flattened catenoid disk of test_a_flattened_patch_of_a_catenoid_restores_to_it
    comes back to within 3% of the flattening with method="hinge" (measured 1.8%: 8.2e-4 of 0.044; the hinge
    energy's discretisation on the grid's right triangles; the bilaplacian steady state is at 2.0e-4, the
    Willmore flow at 2e-7)."""
    W, F, patch = _flattened_catenoid()
    r = dgmesh.fair(W, F, mask=patch, method="hinge")
    flat, got = _catenoid_residual(W[patch]).max(), _catenoid_residual(r.vertices[patch]).max()
    assert flat > 0.03 and got < 0.03 * flat, (flat, got)


def test_the_hinge_method_fairs_a_whole_mesh_by_the_willmore_flow():
    """Without fixed vertices the hinge energy has no boundary data: the Willmore flow runs instead."""
    V, F = shapes.icosphere(2)
    V = V * np.array([1.5, 1.0, 0.8])
    a = dgmesh.fair(V, F, method="hinge", max_iterations=20)
    b = dgmesh.fair(V, F, method="willmore", max_iterations=20)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.energy, b.energy)



def _bi_umbrella(V, F):
    """U0^2 V, the uniform bi-umbrella of a closed mesh (thesis section 3.2), by edge sums."""
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    deg = np.bincount(E.ravel(), minlength=len(V)).astype(float)[:, None]

    def umbrella(X):
        s = np.zeros_like(X)
        np.add.at(s, E[:, 0], X[E[:, 1]])
        np.add.at(s, E[:, 1], X[E[:, 0]])
        return s / deg - X
    return umbrella(umbrella(V))


@pytest.mark.parametrize("level, z0", [(3, 0.3), (5, 0.2)])
def test_the_linear_start_and_the_bilaplacian_steady_state_solve_the_bi_umbrella_system(level, z0):
    """The symmetric form of U0^2 solved by Cholesky (fair.cpp, symmetric_bi_umbrella; CHOLMOD for the
    4.1K-vertex cap) meets U0^2 P = 0 at the movable vertices to rounding: the hinge method's and the
    Willmore flow's linear start (their first iteration) and the bilaplacian flow's steady state, on a
    flattened sphere cap."""
    W, F, movable, _cap = _cap_hole(level=level, z0=z0)
    assert np.abs(_bi_umbrella(W, F)[movable]).max() > 1e-3  # the flat start is far from it
    for method in ("hinge", "willmore"):
        r = dgmesh.fair(W, F, mask=movable, method=method, max_iterations=1)
        assert r.linear_start and r.iterations == 1
        assert np.abs(_bi_umbrella(r.vertices, F)[movable]).max() < 1e-12, method
    r = dgmesh.fair(W, F, mask=movable, method="bilaplacian", tolerance=0.0, max_iterations=60)
    assert np.abs(_bi_umbrella(r.vertices, F)[movable]).max() < 1e-12


def _cotangent_bilaplacian(V, F, X):
    """L M^-1 L X with the cotangent weights L (eq. 3.11) and the mixed (Voronoi) areas M of (V, F)
    (Meyer et al. 2003: Voronoi areas on non-obtuse triangles, else half / a quarter of the area)."""
    n = len(V)
    L = np.zeros((n, n))
    M = np.zeros(n)
    for f in F:
        P = V[f]
        area = 0.5 * np.linalg.norm(np.cross(P[1] - P[0], P[2] - P[0]))
        cot = np.empty(3)
        for k in range(3):
            a, b = P[(k + 1) % 3] - P[k], P[(k + 2) % 3] - P[k]
            cot[k] = a @ b / np.linalg.norm(np.cross(a, b))
        for k in range(3):
            i, j = f[(k + 1) % 3], f[(k + 2) % 3]
            L[i, j] += 0.5 * cot[k]
            L[j, i] += 0.5 * cot[k]
            L[i, i] -= 0.5 * cot[k]
            L[j, j] -= 0.5 * cot[k]
        obtuse = [k for k in range(3) if cot[k] < 0]
        for k in range(3):
            if obtuse:
                M[f[k]] += area / 2 if k in obtuse else area / 4
            else:
                e1 = P[(k + 1) % 3] - P[k]
                e2 = P[(k + 2) % 3] - P[k]
                M[f[k]] += (e1 @ e1 * cot[(k + 2) % 3] + e2 @ e2 * cot[(k + 1) % 3]) / 8
    return L @ ((L @ X) / M[:, None])


def _dented_cap(level=4, z0=0.6, depth=0.2):
    """Unit icosphere with a smooth dent `depth` deep pushed into the cap above z0: (W, F, patch)."""
    V, F = shapes.icosphere(level)
    patch = V[:, 2] > z0
    rho = np.hypot(V[:, 0], V[:, 1]) / np.sqrt(1 - z0 * z0)
    W = V.copy()
    W[patch] *= (1 - depth * np.clip(1 - rho[patch] ** 2, 0, 1) ** 2)[:, None]
    return W, F, patch


def test_the_cotangent_start_solves_the_input_metrics_bilaplacian():
    """start_weights="cotangent": the linear start (the hinge method's first iteration) meets
    L M^-1 L P = 0 at the movable vertices with L and M of the *input* (dented) geometry, the system
    CGAL's PMP::fair solves; the uniform start does not meet it (and the default stays uniform)."""
    W, F, patch = _dented_cap(level=3, z0=0.5)
    scale = np.abs(_cotangent_bilaplacian(W, F, W)[patch]).max()
    r = dgmesh.fair(W, F, mask=patch, method="hinge", start_weights="cotangent", max_iterations=1)
    assert r.linear_start and r.iterations == 1
    assert np.abs(_cotangent_bilaplacian(W, F, r.vertices)[patch]).max() < 1e-10 * scale
    assert np.array_equal(r.vertices[~patch], W[~patch])
    u = dgmesh.fair(W, F, mask=patch, method="hinge", max_iterations=1)
    assert np.abs(_cotangent_bilaplacian(W, F, u.vertices)[patch]).max() > 1e-3 * scale
    assert dgmesh.FairOptions().start_weights.name == "uniform"
    with pytest.raises(dgmesh.MeshError, match="start_weights"):
        dgmesh.fair(W, F, mask=patch, start_weights="voronoi")


def test_a_dented_scan_tip_keeps_its_metric_with_the_cotangent_start():
    """Issue 30, bench fair_repair's hand tip 6% dent as it was to session 24 ("dent_axis": pushed
    along the region's mean normal by 0.3 x its radius): the
    uniform bi-umbrella start knows only the connectivity, and the hinge method from it lands at
    0.0429 of the bbox diagonal from the original (CGAL fair 0.0179); from the cotangent start on the
    dented input's metric at 0.0056 (the dented input itself: 0.0035)."""
    V, F = _cgal_mesh("hand.off")
    sys.path.insert(0, str(ROOT))
    from bench.workloads.fair import damage, patch_distances, region_centre, vertex_ball
    patch = vertex_ball(V, F, region_centre(V, F, "tip"), int(0.06 * len(V)))
    W = damage(V, F, patch, "dent_axis")  # sessions 19-24's dent, which these figures are of
    region = patch[F].any(axis=1)
    diag = np.linalg.norm(np.ptp(V, axis=0))

    def dist(method, **kw):
        r = dgmesh.fair(W, F, mask=patch, method=method, **kw)
        return patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0] / diag

    cot, uni = dist("hinge", start_weights="cotangent"), dist("hinge")
    assert cot < 0.01 and uni > 0.03, (cot, uni)


def test_the_cotangent_starts_fallback_is_reported():
    """start_weights="cotangent" falls back to the uniform start when a movable part has no fixed
    vertex (its cotangent system is singular): the result says so (start_fallback), never a silent
    substitution. Here a closed sphere faired whole beside an open grid whose border is fixed."""
    S, FS = shapes.icosphere(2)
    G, FG = shapes.grid(8, 8)
    G = np.asarray(G, float) + np.array([3.0, 0.0, 0.0])
    G[:, 2] += 0.05 * np.sin(3 * G[:, 0])
    V, F = np.vstack([S, G]), np.vstack([FS, FG + len(S)])
    assert dgmesh.fair(V, F, start_weights="cotangent", max_iterations=3).start_fallback
    assert not dgmesh.fair(V, F, max_iterations=3).start_fallback  # uniform asked, uniform used
    W, F2, patch = _dented_cap(level=3, z0=0.5)
    r = dgmesh.fair(W, F2, mask=patch, method="hinge", start_weights="cotangent", max_iterations=1)
    assert r.linear_start and not r.start_fallback


def test_a_creeping_flow_stops_on_its_progress():
    """min_progress (default 0.01): a region's level stops when the energy fell over its last 8
    accepted steps by less than 1% of the smaller of its fall so far and the energy left. Bench
    fair_repair's hand tip 2% noise: 51 iterations without the rule (not converged, energy 4.509,
    mean distance 0.01527 of the diagonal, 3 samples per face), 25 with it (4.482, 0.01536; measured).
    A closed object faired whole keeps the full flow (its radius spread converges slowly)."""
    V, F = _cgal_mesh("hand.off")
    sys.path.insert(0, str(ROOT))
    from bench.workloads.fair import damage, patch_distances, region_centre, vertex_ball
    patch = vertex_ball(V, F, region_centre(V, F, "tip"), int(0.02 * len(V)))
    W = damage(V, F, patch, "noise")
    region = patch[F].any(axis=1)
    full, r = dgmesh.fair(W, F, mask=patch, min_progress=0), dgmesh.fair(W, F, mask=patch)
    assert r.converged and r.iterations < 0.6 * full.iterations, (r.iterations, full.iterations)
    assert r.energy[-1] < 1.01 * full.energy[-1], (r.energy[-1], full.energy[-1])
    d, d_full = (patch_distances(V, F, region, x.vertices, x.faces, region[x.face_origin])[0] for x in (r, full))
    assert d < 1.03 * d_full, (d, d_full)
    T, FT = shapes.torus(4.0, 1.0, 48, 12)
    assert dgmesh.fair(T, FT).iterations == dgmesh.fair(T, FT, min_progress=0).iterations
    with pytest.raises(dgmesh.MeshError, match="min_progress"):
        dgmesh.fair(T, FT, min_progress=-1)


def test_the_bench_dent_pushes_each_vertex_inwards_by_a_fraction_of_the_feature_size():
    """bench fair_repair's "dent" (issue 30: pushed inwards by a fraction of the local feature size):
    each patch vertex moves along its own inward normal, at most DENT_DEPTH x the inner medial-ball
    radius (1 on the unit sphere); and on a scan's long tip it is a dent, not the near no-op of the
    earlier model ("dent_axis", which slid the femur's 12% tip along itself: 7e-7 of the diagonal)."""
    sys.path.insert(0, str(ROOT))
    from bench.workloads.fair import DENT_DEPTH, damage, patch_distances, region_centre, vertex_ball
    V, F = shapes.icosphere(4)
    V, F = np.asarray(V, float), np.asarray(F)
    patch = V[:, 2] > 0.6
    W = damage(V, F, patch, "dent")
    D = V[patch] - W[patch]
    depth = np.linalg.norm(D, axis=1)
    radial = np.einsum("ij,ij->i", D, V[patch]) / (depth * np.linalg.norm(V[patch], axis=1) + 1e-300)
    assert np.all(radial[depth > 1e-9] > 0.99)  # inwards, along the (radial) normal
    assert np.all(np.linalg.norm(W[patch], axis=1) < 1 + 1e-12)
    assert 0.8 * DENT_DEPTH * np.arccos(0.6) < depth.max() <= DENT_DEPTH * 1.0 + 1e-12, depth.max()
    assert np.array_equal(W[~patch], V[~patch])
    Vf, Ff = _cgal_mesh("femur.off")
    tip = vertex_ball(Vf, Ff, region_centre(Vf, Ff, "tip"), int(0.12 * len(Vf)))
    region = tip[Ff].any(axis=1)
    diag = np.linalg.norm(np.ptp(Vf, axis=0))
    for kind, lo, hi in (("dent", 1e-3, 1.0), ("dent_axis", 0.0, 1e-5)):
        Wf = damage(Vf, Ff, tip, kind)
        d = patch_distances(Vf, Ff, region, Wf, Ff, region)[0] / diag
        assert lo < d < hi, (kind, d)
