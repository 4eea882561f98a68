"""Session 23: grid search of the floor rule steps = A n^p / d^q, d = max(detail, 0.03),
n = sqrt(max(0, sigma^2 - min(a d, cap)^2)) on the rows of an estimates.py output (mean log ratio of the
error to the best count over both sweeps), and which clean meshes it would move. Usage:
floorfit.py EST.json A_LIST CAP_LIST, e.g. floorfit.py est.json 0.8,0.9 0.09,0.1."""
import json, sys, numpy as np, itertools
d = json.load(open(sys.argv[1]))
def arr(lab):
    v = list(d[lab].values()); return (np.array([x['sigma'] for x in v]), np.array([x['detail'] for x in v]),
        [np.array(x['taubin']) / min(x['taubin']) for x in v], list(d[lab]))
S, D, T, K = arr("sweep11"); S2, D2, T2, K2 = arr("sweep31")
CN = list(d["clean"]); CS = np.array([d["clean"][n]['sigma'] for n in CN]); CD = np.array([d["clean"][n]['detail'] for n in CN])
def steps(S, D, A, p, q, a, c):
    Dm = np.maximum(D, 0.03); f = np.minimum(a * Dm, c)
    n2 = np.maximum(0, S**2 - f**2)
    return np.clip(np.round(A * n2**(p/2) / Dm**q), 0, 60).astype(int)
def score(S, D, T, *prm):
    n = steps(S, D, *prm); r = np.array([t[k] for t, k in zip(T, n)]); return np.mean(np.log(r)), r.max()
SA = np.concatenate([S, S2]); DA = np.concatenate([D, D2]); TA = T + T2
print("clean sigma/detail:", " ".join(f"{n}:{s:.3f}/{dd:.3f}" for n, s, dd in zip(CN, CS, CD) if s > 0.02))
for a, c in itertools.product(tuple(map(float, sys.argv[2].split(","))), tuple(map(float, sys.argv[3].split(",")))):
    best = None
    for A in np.exp(np.linspace(np.log(0.5), np.log(400), 44)):
      for p in np.arange(1.0, 3.0, 0.2):
        for q in np.arange(0.0, 2.6, 0.5):
          m = score(SA, DA, TA, A, p, q, a, c)
          if best is None or m[0] < best[0][0]: best = (m, A, p, q)
    m, A, p, q = best
    cs = steps(CS, CD, A, p, q, a, c)
    moved = [f"{n}:{k}" for n, k in zip(CN, cs) if k > 0]
    print(f"a {a:.2f} cap {c:.3f} all-112: {m[0]:.4f} max {m[1]:.3f} A {A:.2f} p {p:.2f} q {q:.2f} | sweep11 {score(S, D, T, A, p, q, a, c)[0]:.4f} sweep31 {score(S2, D2, T2, A, p, q, a, c)[0]:.4f} clean moved {moved}", flush=True)
