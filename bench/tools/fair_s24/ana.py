"""Summary of repair.py's output (argument: its json): means, verdicts against the old column and the peers."""
import json
import sys

import numpy as np

d = json.load(open(sys.argv[1]))
def verdict(a, b, tie=0.05):
    if abs(a - b) <= tie * min(a, b): return "tied"
    return "won" if a < b else "lost"
from collections import Counter
new = np.array([v["new"] for v in d.values()]); old = np.array([v["old"] for v in d.values()])
print("cases", len(d), "mean new %.5f old %.5f" % (new.mean(), old.mean()), "median ratio %.4f" % np.median(new / old))
print("new vs old", Counter(verdict(v["new"], v["old"]) for v in d.values()))
print("within 1%:", sum(abs(v["new"] - v["old"]) <= 0.01 * v["old"] for v in d.values()))
for peer in ("bil", "cgal"):
    print(peer, "new", Counter(verdict(v["new"], v[peer]) for v in d.values() if v[peer]),
          "old", Counter(verdict(v["old"], v[peer]) for v in d.values() if v[peer]))
worse = sorted(d.items(), key=lambda kv: kv[1]["new"] / kv[1]["old"])[-5:]
for k, v in worse: print("worst", k, "%.5f %.5f it %d" % (v["new"], v["old"], v["it"]))
better = sorted(d.items(), key=lambda kv: kv[1]["new"] / kv[1]["old"])[:5]
for k, v in better: print("best", k, "%.5f %.5f it %d" % (v["new"], v["old"], v["it"]))
its = np.array([v["it"] for v in d.values()]); secs = np.array([v["secs"] for v in d.values()])
print("iterations: mean %.1f, at 300: %d; seconds total %.1f" % (its.mean(), (its >= 300).sum(), secs.sum()))
for k in ("full", ):
    x = [(kk, v) for kk, v in d.items() if "full" in v]
    for kk, v in x: print("check", kk, v["full"] == v["old"], v["full_it"], v["it"])
