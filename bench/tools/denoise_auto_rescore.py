"""Re-scores the current default on denoise_auto's subset (seed 11, levels 0.1 / 0.3) against the
tuned peers' errors stored in a denoise_auto result JSON (the same noisy meshes: seed + 1000 level),
without re-running Blender. Usage (from the repository root):

    git show 3bc258e:bench/results/denoise_auto.json > /tmp/peers.json
    /usr/bin/python3 bench/tools/denoise_auto_rescore.py /tmp/peers.json
"""
import json
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "addon")]

import dgmesh  # noqa: E402
from bench.common import cgal_mesh  # noqa: E402
from bench.workloads.denoise import TIE, add_noise, add_noise_isotropic, normal_error  # noqa: E402

peers = json.loads(pathlib.Path(sys.argv[1]).read_text())["data"]
tally = {"won": 0, "tied": 0, "lost": 0}
print("| model | noise | level | default (auto) | auto's choice | previous default | best peer | peer | verdict |")
print("|---|---|---|---|---|---|---|---|---|")
for name in [m for m in peers if m != "tally"]:
    V, F = cgal_mesh(name)
    for kind in ("normal", "isotropic"):
        for lv in (0.1, 0.3):
            add = add_noise if kind == "normal" else add_noise_isotropic
            Vn = add(V, F, lv, 11 + int(lv * 1000))
            r = dgmesh.denoise(Vn, F)
            d = normal_error(r.vertices, V, F)
            pk = peers[name][f"{kind} {lv}"]
            cands = {k: pk[k] for k in ("bilateral (best)", "Laplacian Smooth (best)", "Smooth (best)")}
            pn = min(cands, key=cands.get); peer = cands[pn]
            v = "won" if d < peer * (1 - TIE) else ("tied" if d <= peer * (1 + TIE) else "lost")
            tally[v] += 1
            ch = "filter" if r.options.smoothing_steps == 0 else f"Taubin {r.options.smoothing_steps}"
            print(f"| {name} | {kind} | {lv} | {d:.3f} | {ch} | {pk['default (auto)']:.3f} | {peer:.3f} | {pn} | {v} ({100 * (d / peer - 1):+.1f}%) |", flush=True)
print(f"\nWon {tally['won']}, tied {tally['tied']}, lost {tally['lost']} of {sum(tally.values())} rows.")
