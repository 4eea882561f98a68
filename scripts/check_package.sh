#!/usr/bin/env bash
# Checks the portable add-on zips scripts/package.sh makes; fails (exit 1) when
#   - a module for one of the ABIs in $DGMESH_ABIS (default: 311 313 314) is missing,
#   - ldd finds a dependency outside the zip other than glibc's libraries, or one not found,
#   - a shared object has a RUNPATH other than $ORIGIN, or any RPATH,
#   - a module exports a dynamic symbol other than PyInit__native (libgomp-dgmesh.so.1 is GCC's
#     libgomp renamed: its omp_/GOMP_ ABI is the point of it; any other shared object fails),
#   - the extension zip lacks blender_manifest.toml at its root with platforms = ["linux-x64"],
#     or the legacy zip lacks dgmesh/__init__.py, or the two hold different files.
# Prints the glibc floor (the highest GLIBC_x.y any object needs).
#   bash scripts/check_package.sh EXTENSION_ZIP [LEGACY_ZIP]
set -euo pipefail
zip=${1:?usage: check_package.sh EXTENSION_ZIP [LEGACY_ZIP]}
legacy=${2:-}
abis=${DGMESH_ABIS:-311 313 314}
tmp=$(mktemp -d) && trap 'rm -rf "$tmp"' EXIT
fail=0
bad() { echo "FAIL: $*"; fail=1; }

/usr/bin/python3 -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])' "$zip" "$tmp/ext"
d=$tmp/ext
grep -qx 'platforms = \["linux-x64"\]' "$d/blender_manifest.toml" 2>/dev/null ||
  bad "no blender_manifest.toml with platforms = [\"linux-x64\"] at the zip's root"
for a in $abis; do
  [ -f "$d/_native.cpython-$a-x86_64-linux-gnu.so" ] || bad "no module for cp$a"
done

# glibc's own libraries: the only ones allowed from outside the zip.
glibc='^(libc|libm|libpthread|libdl|librt|libmvec|ld-linux-x86-64|linux-vdso)\.so'
shopt -s nullglob
for so in "$d"/*.so "$d"/*.so.*; do
  n=$(basename "$so")
  # ldd: every dependency must resolve inside the zip or be glibc's.
  while read -r lib arrow path _; do
    [ "$arrow" = "=>" ] || continue
    if [ "$path" = "not" ]; then bad "$n: $lib not found"
    elif [[ "$path" != "$d/"* ]] && ! [[ "$lib" =~ $glibc ]]; then bad "$n: needs $lib from $path"; fi
  done < <(ldd "$so")
  echo "ldd $n: $(ldd "$so" | awk '{print $1}' | tr '\n' ' ')"
  rpath=$(readelf -d "$so" | sed -n 's/.*(RUNPATH).*\[\(.*\)\]/\1/p')
  [ -z "$rpath" ] || [ "$rpath" = '$ORIGIN' ] || bad "$n: RUNPATH $rpath"
  ! readelf -d "$so" | grep -q '(RPATH)' || bad "$n: has an RPATH"
  exported=$(nm -D --defined-only "$so" | awk '{print $3}')
  case $n in
    _native.*) others=$(grep -vx 'PyInit__native' <<<"$exported" || true) ;;
    libgomp-dgmesh.so.1) others="" ;;
    *) others=$exported ;;
  esac
  [ -z "$others" ] || bad "$n exports $(wc -l <<<"$others") other symbols, e.g. $(head -n 3 <<<"$others" | tr '\n' ' ')"
done

if [ -n "$legacy" ]; then
  /usr/bin/python3 -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])' "$legacy" "$tmp/legacy"
  grep -q '^bl_info' "$tmp/legacy/dgmesh/__init__.py" 2>/dev/null || bad "legacy zip: no dgmesh/__init__.py with bl_info"
  diff -r -q "$d" "$tmp/legacy/dgmesh" || bad "the legacy zip's dgmesh/ differs from the extension zip"
fi

floor=$(for so in "$d"/*.so "$d"/*.so.*; do objdump -T "$so"; done |
  grep -o 'GLIBC_[0-9][0-9.]*' | sort -uV | tail -n 1)
echo "glibc floor: $floor; zip size: $(stat -c %s "$zip") bytes ($zip)"
[ "$fail" = 0 ] && echo "check_package: OK" || { echo "check_package: FAILED"; exit 1; }
