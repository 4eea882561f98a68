#!/usr/bin/env bash
# Tests the portable add-on with this machine's (or this lane's) Python and Blender:
# 1. with DGMESH_PACKAGE_PYTESTS=1, the numpy API's tests (tests/python) with /usr/bin/python3
#    against the zip's package, unpacked (its module for that Python's ABI: 3.11 here, 3.13 in
#    trixie, 3.14 in sid);
# 2. a smoke test in Blender: installs the zip the way a user would into fresh, temporary user
#    folders, enables it and runs one operator of each capability from the INSTALLED copy
#    (tests/package/smoke_blender.py).
#   Blender 4.2+: `blender --command extension install-file -r user_default -e ZIP`, then
#                 enables bl_ext.user_default.dgmesh. Where Blender's extensions add-on cannot
#                 load (Debian sid's Blender 5.x: "No module named 'cattrs'"), it says so and installs
#                 the legacy zip instead (Preferences > Add-ons > Install, module dgmesh).
#   Blender 3.4-4.1: the legacy zip (addon_install), module dgmesh.
#   bash scripts/package_test.sh [EXTENSION_ZIP]   (default: dist/dgmesh-<version>-linux-x64.zip;
#                                                   the legacy zip is found beside it)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
version=$(sed -n 's/^__version__ = "\([0-9.]*\)"/\1/p' "$root/addon/dgmesh/__init__.py")
zip=$(realpath "${1:-$root/dist/dgmesh-$version-linux-x64.zip}")
legacy=${zip%.zip}-legacy.zip
[ -f "$zip" ] && [ -f "$legacy" ] || { echo "package_test: $zip or $legacy missing (bash scripts/package.sh)" >&2; exit 2; }

tmp=$(mktemp -d /tmp/dgmesh-package-test.XXXXXX) && trap 'rm -rf "$tmp"' EXIT
# Fresh user folders: nothing from a previous install or the user's own preferences is seen.
export BLENDER_USER_RESOURCES=$tmp/resources BLENDER_USER_CONFIG=$tmp/config
export BLENDER_USER_SCRIPTS=$tmp/scripts BLENDER_USER_EXTENSIONS=$tmp/extensions
mkdir -p "$BLENDER_USER_RESOURCES" "$BLENDER_USER_CONFIG" "$BLENDER_USER_SCRIPTS" "$BLENDER_USER_EXTENSIONS"
ver=$(blender --version 2>/dev/null | sed -n 's/^Blender \([0-9]*\)\.\([0-9]*\).*/\1 \2/p' | head -n 1)
read -r major minor <<<"$ver"
echo "package_test: Blender $major.$minor, $zip"

status=0   # both steps run; either failing fails the script
if [ "${DGMESH_PACKAGE_PYTESTS:-0}" = 1 ]; then  # the whole numpy API suite again: 2-3 minutes
  echo "=== package_test: tests/python against the unpacked zip ($(/usr/bin/python3 --version))"
  bash "$root/scripts/cgal_data.sh" >/dev/null   # meshes some tests read
  /usr/bin/python3 -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])' "$legacy" "$tmp/unpacked"
  (cd "$root" && DGMESH_PACKAGE_DIR=$tmp/unpacked /usr/bin/python3 -m pytest -q -p no:cacheprovider tests/python) ||
    { echo "package_test: FAILED: tests/python against the zip"; status=1; }
fi

echo "=== package_test: smoke test in Blender $major.$minor"
smoke=(blender --background --python-exit-code 1 --python "$root/tests/package/smoke_blender.py" --)
if ((major > 4 || (major == 4 && minor >= 2))); then
  if blender --command extension install-file -r user_default -e "$zip" >"$tmp/install.log" 2>&1; then
    cat "$tmp/install.log"
    "${smoke[@]}" --module bl_ext.user_default.dgmesh --root "$tmp" ||
      { echo "package_test: FAILED: smoke test (extension)"; status=1; }
    exit $status
  fi
  cat "$tmp/install.log"
  if ! grep -q "No module named 'cattrs'" "$tmp/install.log"; then
    echo "package_test: FAILED: extension install-file failed" >&2; exit 1
  fi
  echo "package_test: this Blender's extensions add-on cannot load (cattrs missing); installing the legacy zip instead"
fi
"${smoke[@]}" --module dgmesh --install-legacy "$legacy" --root "$tmp" ||
  { echo "package_test: FAILED: smoke test (legacy add-on)"; status=1; }
exit $status
