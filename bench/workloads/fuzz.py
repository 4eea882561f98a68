"""The long fuzz run (issue #34): tests/python/test_fuzz.py with ``DGMESH_FUZZ=long`` (10000 random
examples per public function, each case in a child process), its seed recorded so that a finding
can be replayed with ``DGMESH_FUZZ_SEED``. The test command runs the bounded, derandomized profile;
this is the run that looks further."""

import os
import random
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

from bench.common import ROOT, table


def fuzz_long(quick):
    seed = random.SystemRandom().randrange(2**31)
    env = dict(os.environ, DGMESH_FUZZ="long", DGMESH_FUZZ_SEED=str(seed))
    with tempfile.TemporaryDirectory() as tmp:
        report = os.path.join(tmp, "fuzz.xml")
        cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={report}",
               str(ROOT / "tests" / "python" / "test_fuzz.py")]
        if quick:  # a smoke test of the workload: two functions
            cmd += ["-k", "validate or uv_stretch"]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        cases = ET.parse(report).getroot().iter("testcase")
        rows = []
        for case in cases:
            failure = case.find("failure")
            if failure is None:  # (an Element without children is falsy: no `or` here)
                failure = case.find("error")
            verdict = "passed" if failure is None else (failure.get("message") or "failed")[:200].replace("|", "/")
            rows.append([case.get("name"), f"{float(case.get('time', 0)):.1f}", verdict])
    failed = [r for r in rows if r[2] != "passed"]
    md = (f"### Fuzz: long run\n\n`DGMESH_FUZZ=long DGMESH_FUZZ_SEED={seed} /usr/bin/python3 -m pytest -q "
          f"tests/python/test_fuzz.py` (hypothesis profile dgmesh-fuzz-long: max_examples 10000 per function; replay a finding with the same seed): "
          f"{len(rows)} tests, {len(failed)} failed, {wall:.0f} s wall, pytest exit status {proc.returncode}.\n\n"
          + table(["test", "seconds", "verdict"], rows) + "\n")
    return {"markdown": md, "data": {"seed": seed, "wall": wall, "returncode": proc.returncode, "rows": rows}}


WORKLOADS = {"fuzz_long": fuzz_long}
