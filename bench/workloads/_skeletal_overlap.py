"""Blender side of the limb benchmark's self-intersection count (run by skeletal_limb.py through
run_blender): for each vertex array of IN.npz (F: the faces, every other key: an n x 3 array), the
number of pairs of triangles sharing no vertex whose interiors intersect (mathutils' BVHTree.overlap).

    blender --background --factory-startup --python bench/workloads/_skeletal_overlap.py -- IN.npz
"""

import json
import os
import sys

import numpy as np
from mathutils.bvhtree import BVHTree


def main(inp):
    d = np.load(inp)
    F = d["F"]
    polys = [tuple(int(x) for x in f) for f in F]
    out = {}
    for key in d.files:
        if key == "F":
            continue
        tree = BVHTree.FromPolygons([tuple(map(float, v)) for v in d[key]], polys, all_triangles=True)
        out[key] = sum(1 for a, b in tree.overlap(tree) if a < b and not set(polys[a]) & set(polys[b]))
    with open(os.environ["DGMESH_BENCH_OUT"], "w") as fh:
        json.dump(out, fh)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:][0])
