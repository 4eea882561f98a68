"""One dgmesh.fair call on issue 30's case with min_progress and max_iterations from the arguments,
for callgrind (--toggle-collect='dgmesh::fair(*' counts the call only, not the set-up)."""
import sys

from _case import dgmesh, issue_case

_, F, patch, W, _, _ = issue_case()
r = dgmesh.fair(W, F, mask=patch, min_progress=float(sys.argv[1]), max_iterations=int(sys.argv[2]))
print("iterations", r.iterations, "E", r.energy[-1])
