#!/usr/bin/env bash
# Runs every test: native (GoogleTest via ctest), the same under ASan+UBSan, the numpy API
# (pytest, Debian's python3), and the add-on inside `blender --background`. Does its own set-up.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/deps.sh
bash scripts/cgal_data.sh >/dev/null

step() { printf '\n=== %s\n' "$*"; }
step "build (Release)"
bash scripts/build.sh
step "native tests"
ctest --test-dir build -j"$(nproc)" --output-on-failure

step "native tests under AddressSanitizer + UndefinedBehaviorSanitizer"
asan=$root/build-asan
[ -f "$asan/CMakeCache.txt" ] || cmake -S "$root" -B "$asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DDGMESH_SANITIZE=ON -DDGMESH_PYTHON=OFF >/dev/null
cmake --build "$asan" -j"$(nproc)"
# OpenMP's runtime keeps thread pools alive at exit: not our leak.
ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir "$asan" -j"$(nproc)" --output-on-failure

step "python tests (numpy API, plain /usr/bin/python3)"
/usr/bin/python3 -m pytest -q tests/python

step "blender tests (blender --background)"
blender --background --factory-startup --python-exit-code 1 --python tests/blender/run.py -- -q tests/blender
