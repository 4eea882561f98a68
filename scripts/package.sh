#!/usr/bin/env bash
# Builds the portable add-on for Linux x86-64:
#   dist/dgmesh-<version>-linux-x64.zip         Blender 4.2+ extension (install-file / drag and drop)
#   dist/dgmesh-<version>-linux-x64-legacy.zip  the same files under dgmesh/ for Blender 3.4-4.1
# One module per CPython ABI (3.11, 3.13, 3.14), each holding the library and every dependency
# statically with hidden symbols; the only outside dependency is glibc (checked at the end by
# scripts/check_package.sh, which also prints the glibc floor). Static libraries and headers are
# fetched and built once into /var/cache/dgmesh (scripts/package_deps.sh); later runs reuse them.
# Builds on this Debian bookworm machine so the glibc floor stays bookworm's.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
start=$SECONDS
cache=${DGMESH_CACHE:-/var/cache/dgmesh}
abis=${DGMESH_ABIS:-311 313 314}
build=$root/build-package

bash scripts/deps.sh                      # compilers, Eigen, nanoflann, Python 3.11 headers
prefix=$(bash scripts/package_deps.sh)    # static PIC libraries, Python 3.13/3.14 and pybind11 headers
echo "=== package: dependencies ready after $((SECONDS - start)) s"

# Python headers per ABI: 3.11 is the host's; 3.13 (trixie) and 3.14 (sid) come unpacked from
# their -dev packages (the multiarch pyconfig.h lives under usr/include/x86_64-linux-gnu).
py_include() {
  case $1 in
    311) echo "/usr/include/python3.11" ;;
    313) local d=$cache/debs/trixie/x/libpython3.13-dev/usr/include; echo "$d/python3.13;$d" ;;
    314) local d=$cache/debs/sid/x/libpython3.14-dev/usr/include; echo "$d/python3.14;$d" ;;
    *) echo "no headers known for ABI $1" >&2; exit 2 ;;
  esac
}
args=(-DDGMESH_PREFIX="$prefix" -DDGMESH_ABIS="${abis// /;}"
      -DDGMESH_PYBIND11_INCLUDE="$cache/debs/trixie/x/pybind11-dev/usr/include")
for a in $abis; do args+=(-DDGMESH_PY${a}_INCLUDE="$(py_include "$a")"); done

echo "=== package: building the modules for ABIs $abis"
cmake -S packaging -B "$build" -DCMAKE_BUILD_TYPE=Release "${args[@]}" >/dev/null
cmake --build "$build" -j"$(nproc)"
rm -rf "$build/stage" && mkdir "$build/stage"
for a in $abis; do cp "$build/package/_native.cpython-$a-x86_64-linux-gnu.so" "$build/stage/"; done
cp "$build/package/libgomp-dgmesh.so.1" "$build/stage/"
strip --strip-unneeded "$build"/stage/*.so*

echo "=== package: zips"
/usr/bin/python3 packaging/make_package.py addon/dgmesh "$build/stage" dist linux-x64
version=$(sed -n 's/^__version__ = "\([0-9.]*\)"/\1/p' addon/dgmesh/__init__.py)
DGMESH_ABIS=$abis bash scripts/check_package.sh "dist/dgmesh-$version-linux-x64.zip" \
  "dist/dgmesh-$version-linux-x64-legacy.zip"
echo "package.sh took $((SECONDS - start)) s"
