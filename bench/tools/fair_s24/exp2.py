"""The hinge from the uniform and the cotangent start on every fair_repair region and damage: distance,
energy after the start and at the end, iterations (start selection by energy). Writes $OUT/energies.json."""
import json

from _case import OUT, B, dgmesh, distance, regions

B._PER_FACE[0] = 1
out = {}
for name, V, F, where, frac, patch, region in regions():
    diag = B.bbox_diagonal(V)
    for kind in ["flat", "dent", "noise"]:
        W = B.damage(V, F, patch, kind)
        row = {}
        try:
            for sw in ["uniform", "cotangent"]:
                r = dgmesh.fair(W, F, mask=patch, method="hinge", start_weights=sw)
                row[sw] = (distance(V, F, region, r, diag), float(r.energy[1]) if len(r.energy) > 1 else None,
                           float(r.energy[-1]), r.iterations)
        except dgmesh.MeshError:
            continue
        key = f"{name}/{where}/{frac}/{kind}"
        out[key] = row
        print(key, row, flush=True)
json.dump(out, open(OUT + "/energies.json", "w"))
