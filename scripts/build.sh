#!/usr/bin/env bash
# Configures and builds everything (library, Python module staged into addon/dgmesh, tests,
# add-on zip) in build/. Serialised by a lock so parallel callers do not trample each other.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${DGMESH_BUILD_DIR:-$root/build}
exec 9>"/tmp/dgmesh-build.lock"
flock 9
# A configure that failed leaves a cache but no Makefile: configure again then.
[ -f "$build/Makefile" ] || cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build" -j"$(nproc)"
