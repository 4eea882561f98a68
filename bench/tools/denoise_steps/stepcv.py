"""Session 25, third part (bench/notes/denoise.md): choosing the third quantity without the held-out rows.
Leave-one-model-out cross-validation on the training sweeps: for each feature x, fit the multiplier
C (x / ref)^r of stepfeat.py on 13 training models (all their rows), score the left-out model's rows
(mean log excess over the best count), pooled over the 14 folds. The rule as is (no multiplier) and a
refitted constant C alone are the baselines. Usage: stepcv.py TRAIN.json,... [FEATURE ...]
(features from FEAT_DIR/f_<stem>.json, default /tmp/s25s, as stepfeat.py)."""
import sys, json, os, pathlib
import numpy as np

FD = pathlib.Path(os.environ.get("FEAT_DIR", "/tmp/s25s"))
rows = []
for f in sys.argv[1].split(","):
    st = pathlib.Path(f).stem; sw = json.load(open(f)); fe = json.load(open(FD / f"f_{st}.json"))
    rows += [dict(model=k.split()[0], t=np.array(r["taubin"]) / min(r["taubin"]), **fe[k]) for k, r in sw.items()]
FEATS = sys.argv[2:] or ["curv", "outl", "nv", "irr", "valstd", "edgecv", "quality", "size", "diag", "detail", "sigma", "curv/detail", "size*curv"]
T = np.log(np.array([r["t"] for r in rows]))
S = np.array([r["sigma"] for r in rows]); D = np.maximum(np.array([r["detail"] for r in rows]), 0.03)
RAW = 9.5 * np.maximum(0, S**2 - np.minimum(0.9 * D, 0.1) ** 2) ** 0.9 / D**1.5
M = np.array([r["model"] for r in rows]); models = sorted(set(M))


def fval(r, f):
    if "/" in f: a, b = f.split("/"); return r[a] / max(r[b], 0.03 if b == "detail" else 1e-9)
    if "*" in f: a, b = f.split("*"); return r[a] * r[b]
    return r[f]


Cs = np.exp(np.linspace(np.log(0.4), np.log(2.5), 41)); Rs = np.linspace(-3, 3, 61)


def losses(x):
    """(len(Cs), len(Rs), rows) log excess of every row under every multiplier."""
    ref = np.median(x); mult = Cs[:, None, None] * (x / ref)[None, None, :] ** Rs[None, :, None]
    n = np.clip(np.round(RAW * mult), 0, 60).astype(int)
    return T[np.arange(len(rows))[None, None, :], n]


def cv(Lg):
    out = np.empty(len(rows))
    for m in models:
        tr = M != m; i = np.unravel_index(np.argmin(Lg[:, :, tr].mean(axis=2)), Lg.shape[:2])
        out[~tr] = Lg[i[0], i[1], ~tr]
    return out


print(f"rule as is: {np.exp(T[np.arange(len(rows)), np.clip(np.round(RAW), 0, 60).astype(int)].mean()) - 1:.2%}")
Lc = losses(np.ones(len(rows)))
print(f"constant C refitted per fold: {np.exp(cv(Lc).mean()) - 1:.2%}")
# the bound for any per-mesh quantity: each model's own best C (in sample, C in [0.4, 2.5])
orc = np.concatenate([Lc[np.argmin(Lc[:, 30, M == m].mean(axis=1)), 30, M == m] for m in models])
print(f"bound, each model's own best C: {np.exp(orc.mean()) - 1:.2%} | C per model: " + " ".join(
    f"{m} {Cs[np.argmin(Lc[:, 30, M == m].mean(axis=1))]:.2f}" for m in models))
for f in FEATS:
    x = np.array([fval(r, f) for r in rows]); x = np.where(x > 0, x, 1e-3)
    c = cv(losses(x)); worst = max(models, key=lambda m: c[M == m].mean())
    print(f"  {f:12s} leave-one-model-out {np.exp(c.mean()) - 1:.2%} | worst {worst} {np.exp(c[M == worst].mean()) - 1:.1%}")
