"""Session 25 (bench/notes/denoise.md): session 23's floor-rule grid search (floorfit.py) redone on sweeps of the
current operator (sweep_op.py): steps = round(A n^p / d^q), d = max(detail, 0.03),
n = sqrt(max(0, sigma^2 - min(a d, cap)^2)), at most 60, minimising the mean log ratio of the error to
the best count's over the training rows. Beside each fit: which noise-free CGAL meshes (a
clean_scans.py output) and which clean jittered superellipsoids of tests/python/test_denoise.py it
would smooth. Usage: opfit.py TRAIN1.json,TRAIN2.json CLEAN.json A_LIST CAP_LIST [A p q a cap ...]
(trailing quintuples: rules to score as given, e.g. the current 5.4 1.6 1.5 0.9 0.1; A_LIST "-": no grid)."""
import sys, json, pathlib, itertools
ROOT = pathlib.Path(__file__).resolve().parents[3]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]
import numpy as np, dgmesh
from rows import cube

rows = {}
for f in sys.argv[1].split(","):
    rows.update({f"{pathlib.Path(f).stem}:{k}": v for k, v in json.load(open(f)).items()})
K = list(rows)
S = np.array([rows[k]["sigma"] for k in K]); D = np.array([rows[k]["detail"] for k in K])
T = np.array([np.array(rows[k]["taubin"]) / min(rows[k]["taubin"]) for k in K])
clean = json.load(open(sys.argv[2]))
CN = list(clean); CS = np.array([clean[n]["sigma"] for n in CN]); CD = np.array([clean[n]["detail"] for n in CN])


SE = [dgmesh.estimate_noise(*cube(j, s)) for j, s in ((0.0, 3), (0.15, 3), (0.3, 3), (0.15, 4))]
SS = np.array([e.sigma for e in SE]); SD = np.array([e.detail for e in SE])
print("superellipsoids sigma/detail:", " ".join(f"{s:.3f}/{d:.3f}" for s, d in zip(SS, SD)))


def raw(S, D, A, p, q, a, c):
    Dm = np.maximum(D, 0.03); f = np.minimum(a * Dm, c)
    return A * np.maximum(0, S**2 - f**2) ** (p / 2) / Dm**q


def steps(*x):
    return np.clip(np.round(raw(*x)), 0, 60).astype(int)


def score(mask, *prm):
    n = steps(S[mask], D[mask], *prm); r = T[mask][np.arange(mask.sum()), n]
    return np.mean(np.log(r)), r.max()


ALL = np.ones(len(K), bool)
seeds = sorted({k.split(":")[0] for k in K})


def report(tag, A, p, q, a, c):
    m = score(ALL, A, p, q, a, c)
    per = " ".join(f"{s} {score(np.array([k.startswith(s + ':') for k in K]), A, p, q, a, c)[0]:.4f}" for s in seeds)
    cs = steps(CS, CD, A, p, q, a, c)
    moved = [f"{n}:{k}" for n, k in zip(CN, cs) if k > 0]
    se = raw(SS, SD, A, p, q, a, c)
    print(f"{tag} a {a:.2f} cap {c:.3f} A {A:.2f} p {p:.2f} q {q:.2f}: mean log {m[0]:.4f} (excess {np.exp(m[0]) - 1:.2%}) "
          f"max {m[1]:.3f} | {per} | clean moved {moved} | superellipsoid raw steps {np.round(se, 2).tolist()}", flush=True)
    return m[0], moved, se.max()


extra = [float(x) for x in sys.argv[5:]]
for i in range(0, len(extra), 5):
    report("given", *extra[i:i + 5])
base_moved = None
for a, c in [] if sys.argv[3] == "-" else itertools.product(tuple(map(float, sys.argv[3].split(","))), tuple(map(float, sys.argv[4].split(",")))):
    best, best_ok = None, None
    for A in np.exp(np.linspace(np.log(0.5), np.log(400), 60)):
        for p in np.arange(1.0, 3.01, 0.1):
            for q in np.arange(0.0, 2.51, 0.25):
                m = score(ALL, A, p, q, a, c)[0]
                if best is None or m < best[0]:
                    best = (m, A, p, q)
                # the clean constraint: no CGAL mesh smoothed beyond the four the current rule smooths,
                # and every superellipsoid below half a step
                if best_ok is None or m < best_ok[0]:
                    cs = steps(CS, CD, A, p, q, a, c)
                    extra_moved = [n for n, k in zip(CN, cs) if k > 0 and n not in ("b9_mesh", "bones", "femur", "knot2")]
                    if not extra_moved and raw(SS, SD, A, p, q, a, c).max() < 0.5:
                        best_ok = (m, A, p, q)
    report("free      ", best[1], best[2], best[3], a, c)
    if best_ok:
        report("clean-kept", best_ok[1], best_ok[2], best_ok[3], a, c)
