"""Session 25 (bench/notes/denoise.md): held-out check of step rules on sweep_op.py outputs (heldout.py's
pattern: mean excess of the error over the best count's, the session-23 constants against a refit),
pooled over the files, by file, by level and per row. Usage:
opheld.py SWEEP1.json[,SWEEP2.json...] A p q a cap [A p q a cap] [--rows]."""
import sys, json, pathlib
import numpy as np

rows = {}
for f in sys.argv[1].split(","):
    rows.update({f"{pathlib.Path(f).stem}:{k}": v for k, v in json.load(open(f)).items()})
args = [a for a in sys.argv[2:] if a != "--rows"]
rules = [tuple(map(float, args[i:i + 5])) for i in range(0, len(args), 5)]


def steps(s, d, A, p, q, a, c):  # native/src/denoise.cpp auto_smoothing_steps with these constants
    d = max(d, 0.03); n = np.sqrt(max(0.0, s * s - min(a * d, c) ** 2))
    return int(min(60, np.floor(A * n**p / d**q + 0.5)))


K = list(rows)
R = np.array([[rows[k]["taubin"][steps(rows[k]["sigma"], rows[k]["detail"], *r)] / min(rows[k]["taubin"]) for r in rules] for k in K])
L = np.log(R)


def line(tag, m):
    print(f"{tag:28s} rows {m.sum():3d} | " + " | ".join(f"{np.exp(L[m, i].mean()) - 1:7.2%} (max {R[m, i].max() - 1:6.1%})" for i in range(len(rules))))


print("rules:", " ; ".join(f"{A} n^{p} / d^{q}, floor min({a} d, {c})" for A, p, q, a, c in rules))
line("all", np.ones(len(K), bool))
for f in sorted({k.split(":")[0] for k in K}):
    line(f, np.array([k.startswith(f + ":") for k in K]))
for mdl in sorted({k.split(":")[1].split()[0] for k in K}):
    line(f"model {mdl}", np.array([k.split(":")[1].split()[0] == mdl for k in K]))
for lv in sorted({k.split()[-1] for k in K}):
    line(f"level {lv}", np.array([k.split()[-1] == lv for k in K]))
for kind in ("normal", "isotropic"):
    line(kind, np.array([f" {kind} " in k for k in K]))
print("better / worse by > 1 %:", " ; ".join(f"rule {i}: {(R[:, i] < R[:, 0] / 1.01).sum()} / {(R[:, i] > R[:, 0] * 1.01).sum()}" for i in range(1, len(rules))))
if "--rows" in sys.argv:
    for j, k in enumerate(K):
        t = np.array(rows[k]["taubin"])
        print(f"{k:42s} best {t.argmin():2d} {t.min():6.3f} | " + " | ".join(
            f"{steps(rows[k]['sigma'], rows[k]['detail'], *r):2d} {t[steps(rows[k]['sigma'], rows[k]['detail'], *r)]:6.3f}" for r in rules))
