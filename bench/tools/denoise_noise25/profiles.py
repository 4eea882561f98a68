"""Session 25: the residual-against-width profiles (robust sigma of the standardised residual, e units, for
quadric (d2) and cubic (d3) fits of 12-48 points) of chosen rows of multiscale.py outputs, side by side.
Usage: profiles.py OUT.json "ROW1;ROW2;..." (rows as 'bull normal 0.0')."""
import sys, json
d = {}
for f in sys.argv[1].split(","):
    d.update(json.load(open(f)))
rows = sys.argv[2].split(";")
cols = [k for k in d[rows[0]] if k.startswith("d")]
print(f"{'row':34s}" + "".join(f"{c:>7s}" for c in cols))
for r in rows:
    print(f"{r:34s}" + "".join(f"{d[r][c]['sigma']:7.3f}" for c in cols))
