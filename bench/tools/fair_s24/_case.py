"""What the session-24 fair experiments share (bench/notes/fair.md cites them): the checkout's paths,
fair_repair's damaged regions and issue 30's speed case. Each script writes its data to $OUT
(default /tmp/dgmesh-fair-s24)."""

import os
import resource
import sys
from pathlib import Path

REPO = str(Path(__file__).resolve().parents[3])  # the checkout these scripts lie in
OUT = os.environ.get("OUT", "/tmp/dgmesh-fair-s24")
os.makedirs(OUT, exist_ok=True)
sys.path.insert(0, REPO)
sys.path.insert(0, REPO + "/addon")

import dgmesh  # noqa: E402
from bench.workloads import fair as B  # noqa: E402

SEED = int(os.environ.get("SEED", "0"))  # region_centre's seed (0: fair_repair's regions)


def regions(meshes=None, wheres=("tip", "saddle", "flat"), fracs=(0.02, 0.06, 0.12), seed=SEED):
    """fair_repair's regions: (name, V, F, where, frac, patch, region faces) for each mesh, place, fraction."""
    for name in meshes or B._REPAIR_MESHES:
        V, F = B.cgal_mesh(name)
        for where in wheres:
            centre = B.region_centre(V, F, where, seed=seed)
            for frac in fracs:
                patch = B.vertex_ball(V, F, centre, max(int(frac * len(V)), 8))
                yield name, V, F, where, frac, patch, B._region_of(F, patch)[0]


def damaged(wheres=("tip", "saddle", "flat"), kinds=("flat", "dent", "noise")):
    """Each region of regions() under each damage: (name, V, F, where, frac, patch, region faces, kind,
    damaged vertices, bbox diagonal)."""
    for name, V, F, where, frac, patch, region in regions(wheres=wheres):
        diag = B.bbox_diagonal(V)
        for kind in kinds:
            yield name, V, F, where, frac, patch, region, kind, B.damage(V, F, patch, kind), diag


def issue_case():
    """Issue 30's speed case (bench fair_speed): armadillo 1-to-4, 6% around the most saddle-like
    vertex flattened. Returns V, F, patch, W (damaged), region faces, bbox diagonal."""
    V, F = B.cgal_mesh("armadillo")
    V, F = dgmesh.shapes.subdivide_linear(V, F)
    patch = B.vertex_ball(V, F, B.region_centre(V, F, "saddle"), int(0.06 * len(V)))
    return V, F, patch, B.damage(V, F, patch, "flat"), B._region_of(F, patch)[0], B.bbox_diagonal(V)


def distance(V, F, region, r, diag):
    """Mean restored <-> original distance of a dgmesh.fair result over the bbox diagonal (fair_repair's measure)."""
    return B.patch_distances(V, F, region, r.vertices, r.faces, region[r.face_origin])[0] / diag


def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
