#!/usr/bin/env bash
# The demo: runs every operator on real meshes in `blender --background` and writes .blend files,
# PNG renders and a summary to out/. Does its own set-up (deps, build, data).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/deps.sh
bash scripts/build.sh
bash scripts/cgal_data.sh >/dev/null
mkdir -p out
blender --background --factory-startup --python-exit-code 1 --python scripts/demo.py -- "$root/out"
echo "demo: wrote $(ls out | wc -l) files to out/ (see out/summary.md)"
