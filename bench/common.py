"""Shared helpers of the benchmark workloads: timing, test meshes, machine facts, Blender runs."""

import datetime
import json
import os
import pathlib
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "addon"))

import dgmesh  # noqa: E402
from dgmesh import shapes  # noqa: E402,F401  (re-exported for workloads)

IMAGES = ROOT / "bench" / "images"


def median_time(fn, repeats=5, warmup=1):
    """Median wall time of fn() over `repeats` runs after `warmup` runs: (seconds, last result)."""
    result = None
    for _ in range(warmup):
        result = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def interleaved_medians(fns, repeats=15, warmup=1):
    """Median wall times (seconds) of each of `fns`, called in turn `repeats` times (A/B interleaved:
    a shared machine's load changes alike for all of them)."""
    for fn in fns:
        for _ in range(warmup):
            fn()
    times = [[] for _ in fns]
    for _ in range(repeats):
        for fn, t in zip(fns, times):
            t0 = time.perf_counter()
            fn()
            t.append(time.perf_counter() - t0)
    return [statistics.median(t) for t in times]


def cgal_dir():
    """Folder of Debian's CGAL data meshes, unpacked on first use (never committed)."""
    out = subprocess.run(["bash", str(ROOT / "scripts" / "cgal_data.sh")], check=True,
                         capture_output=True, text=True)
    return pathlib.Path(out.stdout.strip())


def cgal_mesh(name):
    """(V, F) of a CGAL data mesh by file stem, e.g. 'fandisk', 'bunny00', 'armadillo'."""
    return dgmesh.read_mesh(cgal_dir() / f"{name}.off")


def cgal_tool(src_name, probe_header, build=True, extra_flags=()):
    """Path of a bench-only CGAL reference tool bench/tools/<src_name> (e.g. "cgal_fair_hole.cpp"),
    compiled with g++ against Debian's libcgal-dev into .cache/<stem> on first use and whenever the
    source is newer or the compile command changed (tens of seconds; not when `build` is False).
    `probe_header` is a header below /usr/include that the tool needs (e.g.
    "CGAL/Polygon_mesh_processing/fair.h"); `extra_flags` go before the default include paths (e.g.
    an -I of patched headers). Returns None when the tool is not built and cannot be: no g++, no
    CGAL headers, or `build` False. Built without OpenMP, so the tools run single-threaded."""
    src = ROOT / "bench" / "tools" / src_name
    exe = ROOT / ".cache" / src.stem
    stamp = exe.with_suffix(".cmd")
    cmd = ["g++", "-O2", "-std=c++17", "-DNDEBUG", "-DCGAL_EIGEN3_ENABLED", *extra_flags, "-I/usr/include/eigen3",
           str(src), "-o", str(exe.with_suffix(".tmp")), "-lgmp", "-lmpfr"]
    # No stamp: built by an older helper with the default command (no extra flags).
    built_cmd = stamp.read_text() if stamp.exists() else (" ".join(cmd) if not extra_flags else "")
    if exe.exists() and exe.stat().st_mtime >= src.stat().st_mtime and built_cmd == " ".join(cmd):
        return exe
    if not build or not shutil.which("g++") or not (pathlib.Path("/usr/include") / probe_header).exists():
        return None
    exe.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(cmd, check=True)
    os.replace(exe.with_suffix(".tmp"), exe)
    stamp.write_text(" ".join(cmd))
    return exe


def loop_subdivide(V, F, levels):
    return shapes.loop_subdivide(V, F, levels)


def bbox_diagonal(V):
    return float(((V.max(0) - V.min(0)) ** 2).sum() ** 0.5)


def peak_rss_mb():
    """Peak resident memory of this process so far, in MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def machine():
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                         capture_output=True, text=True).stdout.strip()
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "threads": dgmesh.num_threads(),
        "python": platform.python_version(),
        "date": datetime.date.today().isoformat(),
        "commit": rev or "unknown",
    }


def table(headers, rows):
    """A markdown table; floats get 4 significant digits."""
    def fmt(x):
        return f"{x:.4g}" if isinstance(x, float) else str(x)

    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(fmt(x) for x in row) + " |" for row in rows]
    return "\n".join(lines)


def run_blender(script, args=(), timeout=1800):
    """Runs `script` inside `blender --background` with the add-on importable; the script writes
    a JSON result to the path in env DGMESH_BENCH_OUT, which is returned parsed."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "result.json"
        env = dict(os.environ, DGMESH_BENCH_OUT=str(out),
                   PYTHONPATH=str(ROOT / "addon") + os.pathsep + os.environ.get("PYTHONPATH", ""))
        cmd = ["blender", "--background", "--factory-startup", "--python-exit-code", "1",
               "--python", str(script), "--", *map(str, args)]
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        if proc.returncode != 0 or not out.exists():
            raise RuntimeError(f"blender run failed ({proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
        return json.loads(out.read_text())
