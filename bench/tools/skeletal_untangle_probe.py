"""Issue 33's untangling on the capsule of bench/tools/skeletal_crease_probe.py (r 0.5, length 6,
64 x 10 x 128, the rig's Gaussian weights; DQS = skeletal_subspace_deform with the same weights), whole
mesh and through the multiresolution layer (5000-face control mesh): self-intersecting pairs over the
whole mesh (native dgmesh.skeletal.self_intersecting_pairs, equal pair for pair to the probe's numpy
count) and the minimum ratio of the distance to the bones (posed / rest, both bones) over all vertices,
for bends of 45 / 90 / 135 degrees and twists of 90 / 180.

    /usr/bin/python3 bench/tools/skeletal_untangle_probe.py
"""
import sys
from pathlib import Path

import numpy as np

sys.path[:0] = [str(Path(__file__).resolve().parents[2] / "addon"), str(Path(__file__).resolve().parent)]
from dgmesh.skeletal import capsule, skeletal_subspace_deform, self_intersecting_pairs  # noqa: E402
from skeletal_crease_probe import REST, bone_ratio_min, probe_poses, probe_rigs  # noqa: E402


def main():
    V, F = capsule(0.5, 6.0, 64, 10, 128)
    rigs = probe_rigs(V, F)
    for name, R in probe_poses().items():
        pose = np.array([REST[0], R @ REST[1]])
        X = skeletal_subspace_deform(V, rigs["whole"].weights, REST, pose, dual_quaternion=True)
        print("%-9s DQS %5d (%.3f)" % (name, len(self_intersecting_pairs(X, F)), bone_ratio_min(X, V, pose)), end="")
        for path, rig in rigs.items():
            for label, opt in (("default", {}), ("untangle 20", {"untangle_iterations": 20})):
                X = rig.deform(pose, **opt)
                print("  %s %s %5d (%.3f)" % (path, label, len(self_intersecting_pairs(X, F)),
                                              bone_ratio_min(X, V, pose)), end="")
        print(flush=True)


if __name__ == "__main__":
    main()
