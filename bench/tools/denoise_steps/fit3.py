"""Step 3: grid search of steps = a sigma^p / max(detail, 0.03)^q / max(c36, 0.05)^r minimising the
mean log ratio of the error to the best count's. Usage: fit3.py SWEEPk.json"""
import json
import sys

import numpy as np
tr = json.load(open(sys.argv[1]))
rows = list(tr.values())
T = [np.array(v['taubin']) / min(v['taubin']) for v in rows]
S = np.array([v['sigma'] for v in rows]); S19=S
D36 = np.sqrt(np.maximum(0, np.array([v['s36'] for v in rows])**2 - S**2))
D27 = np.sqrt(np.maximum(0, np.array([v['s27'] for v in rows])**2 - S**2))
C36 = np.array([v['c36'] for v in rows]); C = np.array([v['curv'] for v in rows])
def score(n):
    n = np.clip(np.round(n), 0, 60).astype(int)
    r = np.array([t[k] for t, k in zip(T, n)])
    return np.mean(np.log(r)), r.max()
def search(X, name):
    best = None
    for a in np.exp(np.linspace(np.log(0.3), np.log(400), 60)):
        for p in np.arange(0.8, 2.8, 0.1):
            for q in np.arange(0.0, 2.6, 0.25):
                for r in np.arange(0.0, 2.1, 0.5):
                    m = score(a * S**p / np.maximum(X, 0.03)**q / np.maximum(C36, 0.05)**r)
                    if best is None or m[0] < best[0][0]: best = (m, a, p, q, r)
    print(name, "mean log %.4f max %.3f" % best[0], "a %.2f p %.2f q %.2f r(c36) %.2f" % best[1:], flush=True)
search(D36, "d36")
search(D27, "d27")
