"""Curvature-derivative errors between the crest_derivatives bench's noise levels (issue #31): RMS
error of e_max / e_min of the noise-adaptive jet fit (the default), the jet fit alone (noise_adaptive=False), the
thesis fit (jet=False) and CGAL's
jet fitting (d = 3, m = 3) at low Gaussian noise, where the noise test switches fits. Same surfaces,
measured vertices, seeds and noise model as bench/workloads/crest.py crest_derivatives.

    /usr/bin/python3 bench/tools/crest_noise_sweep.py [surfaces, e.g. 1,6,8] [noise levels, e.g. 0.001,0.002]
"""

import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "addon"))

import dgmesh  # noqa: E402
from bench.workloads import crest as C  # noqa: E402


def main():
    S = C.derivative_surfaces()
    picks = [int(a) for a in sys.argv[1].split(",")] if len(sys.argv) > 1 else range(1, len(S) + 1)
    noises = [float(a) for a in sys.argv[2].split(",")] if len(sys.argv) > 2 else [0.001, 0.002, 0.005, 0.01, 0.02]
    print("| surface | noise | ratio | jet k=1 | jet k=2 | jet alone k=1 | thesis k=1 | thesis k=2 | CGAL 2-ring "
          "| CGAL 3-ring |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for si in picks:
        name, (V0, F), f = S[si - 1]
        mask = C._measured(V0, F, f)
        for s in noises:
            V = V0 if s == 0 else C._noisy(V0, F, s, 100 + si - 1)
            cells = []
            for k, o in [(1, dict(jet=True)), (2, dict(jet=True)), (1, dict(jet=True, noise_adaptive=False)),
                         (1, dict(jet=False)), (2, dict(jet=False))]:
                d = dgmesh.curvature_derivatives(V, F, rings=k, **o)
                if k == 1 and o.get("jet") and "noise_adaptive" not in o:
                    ratio = f"{d.noise_ratio:.2f}" + ("" if d.jet_used else " (thesis fit)")
                cells.append("%.4f / %.4f" % C._errors(d, f, mask))
            for k in (2, 3):
                c = C.cgal_jet(V, C._rings(V, F, k), f[6])
                cells.append("-" if c is None else "%.4f / %.4f" % C._errors(c, f, mask))
            print(f"| ({si}) | {s:g} | {ratio} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
