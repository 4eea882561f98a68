"""The thesis's three flows on fair_repair's damaged regions (issue 30, session 28): the default
Willmore flow, the Laplacian-of-H flow (eq. 3.12, method="laplacian_of_h", both with the linear start)
and the bilaplacian flow, each with its defaults; mean distance / bbox diagonal (fair_repair's
measure) per region, then won / tied / lost (5 %) of each pair by place and by damage. Writes
$OUT/methods_seed$SEED.json.

    /usr/bin/python3 bench/tools/fair_s28/methods.py
"""
import collections
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fair_s24"))  # the shared _case
from _case import OUT, SEED, B, dgmesh, distance, damaged  # noqa: E402

METHODS = ("willmore", "laplacian_of_h", "bilaplacian")
B._PER_FACE[0] = 1
rows = []
for name, V, F, where, frac, patch, region, kind, W, diag in damaged():
    try:
        r = {m: distance(V, F, region, dgmesh.fair(W, F, mask=patch, method=m), diag) for m in METHODS}
    except dgmesh.MeshError:
        continue  # (as fair_repair: a region dgmesh.fair refuses)
    rows.append(dict(name=name, where=where, frac=frac, kind=kind, **r))
    print(rows[-1], flush=True)
json.dump(rows, open(f"{OUT}/methods_seed{SEED}.json", "w"))


def verdict(a, b, tie=0.05):
    return "won" if a < (1 - tie) * b else "lost" if a > (1 + tie) * b else "tied"


print(len(rows), "regions")
for a, b in (("laplacian_of_h", "willmore"), ("laplacian_of_h", "bilaplacian"), ("willmore", "bilaplacian")):
    for key in ("all", "where", "kind"):
        groups = collections.defaultdict(list)
        for r in rows:
            groups["all" if key == "all" else r[key]].append(r)
        cells = []
        for g, rs in sorted(groups.items()):
            c = collections.Counter(verdict(r[a], r[b]) for r in rs)
            cells.append("%s %d/%d/%d (means %.5f / %.5f)" % (g, c["won"], c["tied"], c["lost"],
                                                             sum(r[a] for r in rs) / len(rs), sum(r[b] for r in rs) / len(rs)))
        print(f"{a} vs {b}:", "; ".join(cells))
