"""Benchmark runner: runs named workloads and rewrites bench/RESULTS.md.

    /usr/bin/python3 bench/run.py                 # every workload
    /usr/bin/python3 bench/run.py curvature       # some of them
    /usr/bin/python3 bench/run.py --quick ...     # small sizes (a smoke test, not for RESULTS.md)
    /usr/bin/python3 bench/run.py --list

Each workload module in bench/workloads/ exposes WORKLOADS = {name: fn(quick) -> {"markdown",
"data"}}. Results go to bench/results/<name>.md and .json; RESULTS.md is rebuilt from all of them,
so running one workload keeps the others' latest figures.
"""

import argparse
import importlib
import json
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import common  # noqa: E402

RESULTS = ROOT / "bench" / "results"


def discover():
    found = {}
    for path in sorted((ROOT / "bench" / "workloads").glob("*.py")):
        if path.stem.startswith("_"):
            continue
        module = importlib.import_module(f"bench.workloads.{path.stem}")
        for name, fn in getattr(module, "WORKLOADS", {}).items():
            found[name] = fn
    return found


def rebuild_results_md():
    parts = [
        "# Benchmark results",
        "",
        "Written by `bench/run.py` (in-process timers around the algorithm, median of several runs).",
        "Re-run one workload with `/usr/bin/python3 bench/run.py <name>`; each section names its",
        "machine, date and commit.",
        "",
    ]
    for md in sorted(RESULTS.glob("*.md")):
        parts += [md.read_text().rstrip(), ""]
    (ROOT / "bench" / "RESULTS.md").write_text("\n".join(parts))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("names", nargs="*")
    ap.add_argument("--quick", action="store_true", help="small sizes; results are not written")
    ap.add_argument("--list", action="store_true")
    args = ap.parse_args()
    workloads = discover()
    if args.list:
        print("\n".join(workloads))
        return 0
    unknown = [n for n in args.names if n not in workloads]
    if unknown:
        print(f"unknown workload(s): {unknown}; known: {list(workloads)}", file=sys.stderr)
        return 2
    RESULTS.mkdir(parents=True, exist_ok=True)
    for name in args.names or list(workloads):
        t0 = time.perf_counter()
        print(f"--- {name}", flush=True)
        res = workloads[name](args.quick)
        m = common.machine()
        header = (f"## {name}\n\n_{m['date']}, commit {m['commit']}, {m['cpu']}, {m['cores']} cores, "
                  f"{m['threads']} threads; run: `/usr/bin/python3 bench/run.py {name}`_\n\n")
        print(res["markdown"])
        print(f"--- {name} done in {time.perf_counter() - t0:.1f} s", flush=True)
        if args.quick:
            continue
        (RESULTS / f"{name}.md").write_text(header + res["markdown"].rstrip() + "\n")
        (RESULTS / f"{name}.json").write_text(json.dumps({"machine": m, "data": res["data"]}, indent=1,
                                                         default=float))
    if not args.quick:
        rebuild_results_md()
    return 0


if __name__ == "__main__":
    sys.exit(main())
