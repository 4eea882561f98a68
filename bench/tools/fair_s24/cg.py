import sys
from pathlib import Path as _Path
REPO = str(_Path(__file__).resolve().parents[3])  # the checkout this script lies in
OUT = __import__("os").environ.get("OUT", "/tmp/dgmesh-fair-s24")  # where its data goes
sys.path.insert(0, REPO + '/addon')
import numpy as np, dgmesh
d = np.load(OUT + '/case.npz')
r = dgmesh.fair(d['W'], d['F'], mask=d['patch'], min_progress=float(sys.argv[1]), max_iterations=int(sys.argv[2]))
print("iterations", r.iterations, "E", r.energy[-1])
