#!/usr/bin/env bash
# Runs every test, in every lane: this machine (Debian bookworm, Blender 3.4) with native tests
# (GoogleTest via ctest, also under ASan+UBSan), the numpy API (pytest) and the add-on inside
# `blender --background`; then the same, without the sanitizer build, inside the Debian roots of
# scripts/lanes.sh (trixie: Blender 4.3, sid: Blender 5.x). Does its own set-up.
#   bash scripts/test.sh              everything (the README's test command; .ci/run)
#   bash scripts/test.sh --here       this machine's lane only
#   bash scripts/test.sh --lane SUITE what scripts/lanes.sh runs inside a root
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
mode=${1:-all}
lane=bookworm
[ "$mode" = --lane ] && lane=${2:?--lane takes the suite}

step() { printf '\n=== [%s] %s\n' "$lane" "$*"; }
# A test step that fails is reported at the end; the later steps still run.
failed=()
check() { "$@" || failed+=("$current"); }
if [ "$mode" = --lane ]; then bash scripts/deps.sh --lane; else bash scripts/deps.sh; fi
bash scripts/cgal_data.sh >/dev/null
if [ "$mode" = all ]; then
  # The lanes' roots (debootstrap and apt: mostly download and unpacking) are made meanwhile.
  mkdir -p build
  bash scripts/lanes.sh --prepare >build/lanes-prepare.log 2>&1 &
  prepare=$!
fi

if [ "$mode" != --lane ]; then
  # Style is checked once, with bookworm's tools (newer ones format and warn differently).
  step "lint (pyflakes: scripts/lint.py)"; current="lint"
  check /usr/bin/python3 scripts/lint.py
  step "format (clang-format --dry-run -Werror, .clang-format)"; current="format"
  mapfile -t cxx < <(git ls-files 'native/*.h' 'native/*.cpp' 'tests/native/*.cpp' 'tests/native/*.h' \
    'packaging/*.cpp' 'bench/tools/*.cpp' 2>/dev/null || find native tests/native -name '*.[ch]*')
  check clang-format --dry-run -Werror "${cxx[@]}"
fi

step "build (Release)"
bash scripts/build.sh
step "native tests"; current="native tests"
check ctest --test-dir build -j"$(nproc)" --output-on-failure

# The sanitizer build and its tests (bookworm only), the python tests and the Blender tests run side
# by side: the test suites leave a core idle much of the time (one process, waits), so together they
# take less time than one after the other. Each background job writes a log, shown when it is done.
jobs_pids=(); jobs_names=(); jobs_logs=()
background() {  # background NAME LOG CMD...: runs CMD with its output in LOG
  local name=$1 log=$2; shift 2
  "$@" >"$log" 2>&1 &
  jobs_pids+=($!); jobs_names+=("$name"); jobs_logs+=("$log")
}
asan_tests() {  # the native tests built with AddressSanitizer + UndefinedBehaviorSanitizer
  local asan=$root/build-asan
  # -O1 -g1 (line tables for the reports' stacks): the build takes 45% less CPU than -O2 -g (792 s
  # against 1452 s), the tests 10% more (116 s against 105 s; bench/tools/asan_flags.sh, load 3-7);
  # it was the run's long pole.
  cmake -S "$root" -B "$asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
    -DDGMESH_SANITIZE=ON -DDGMESH_PYTHON=OFF >/dev/null
  cmake --build "$asan" -j"$(nproc)" || return
  # OpenMP's runtime keeps thread pools alive at exit: not our leak.
  ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 ctest --test-dir "$asan" -j"$(nproc)" --output-on-failure
}
[ "$mode" = --lane ] || background "native tests under ASan+UBSan" build/asan-tests.log asan_tests
background "python tests" build/python-tests.log /usr/bin/python3 -m pytest -q tests/python

step "blender tests ($(blender --version 2>/dev/null | head -n 1), --background)"; current="blender tests"
check blender --background --factory-startup --python-exit-code 1 --python tests/blender/run.py -- -q tests/blender
for i in "${!jobs_pids[@]}"; do
  current=${jobs_names[$i]}
  step "$current (ran beside the blender tests; its log: ${jobs_logs[$i]})"
  check wait "${jobs_pids[$i]}"
  cat "${jobs_logs[$i]}"
done

# The portable package (scripts/package.sh, built here; the lanes get a copy of dist/): installed
# into fresh user folders of this lane's Blender, one operator of each capability.
if [ "$mode" != --lane ]; then
  step "portable package: build and check (scripts/package.sh)"; current="portable package"
  check bash scripts/package.sh
fi
step "portable package: installed in $(blender --version 2>/dev/null | head -n 1)"; current="portable package install"
check bash scripts/package_test.sh

if ((${#failed[@]})); then
  printf '\n!!! [%s] failed: %s\n' "$lane" "$(IFS=,; echo "${failed[*]}")"
else
  printf '\n=== [%s] every test passed\n' "$lane"
fi
if [ "$mode" = all ]; then
  wait "$prepare" || true  # a root it could not make is made again, or skipped, by the run
  step "test lanes in Debian roots"
  cat build/lanes-prepare.log
  current="lanes"
  check bash scripts/lanes.sh
fi
((${#failed[@]} == 0))
