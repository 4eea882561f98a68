#!/usr/bin/env bash
# CPU time of the sanitizer build (scripts/test.sh asan_tests) and of its tests, for two flag sets:
# -O1 -g1 (what test.sh uses) against -O2 -g (CMake's RelWithDebInfo). No ccache.
#   OUT=/tmp/asan bash bench/tools/asan_flags.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${OUT:-/tmp/asan-flags}
mkdir -p "$out"
for v in O1g1 O2g; do
  d=$out/$v
  case $v in O1g1) f="-O1 -g1 -DNDEBUG" ;; O2g) f="-O2 -g -DNDEBUG" ;; esac
  cmake -S "$root" -B "$d" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDGMESH_SANITIZE=ON -DDGMESH_PYTHON=OFF \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$f" >/dev/null
  echo "$v build, load $(cut -d' ' -f1 /proc/loadavg)"
  /usr/bin/time -f "$v build: wall %e s user %U s sys %S s" cmake --build "$d" -j"$(nproc)" >"$d.build.log" 2>&1
  tail -n 1 "$d.build.log"
  ASAN_OPTIONS=detect_leaks=0 /usr/bin/time -f "$v tests: wall %e s user %U s sys %S s" \
    ctest --test-dir "$d" -j"$(nproc)" >"$d.test.log" 2>&1 || true
  tail -n 1 "$d.test.log"; grep "tests passed" "$d.test.log"
done
