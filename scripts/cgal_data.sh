#!/usr/bin/env bash
# Unpacks Debian's CGAL data meshes (scanned models) into the cache and prints the mesh folder.
# Idempotent; the meshes are never committed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dest=${DGMESH_DATA:-$root/.cache/cgal-data}
if [ ! -f "$dest/.unpacked" ]; then
  tarball=""
  for t in /usr/share/doc/libcgal-dev/data.tar.gz /usr/share/doc/libcgal-demo/data.tar.gz; do
    [ -f "$t" ] && tarball=$t && break
  done
  [ -n "$tarball" ] || { echo "cgal_data: data.tar.gz not found (apt-get install libcgal-demo)" >&2; exit 1; }
  mkdir -p "$dest"
  tar xzf "$tarball" -C "$dest" --wildcards 'data/meshes/*'
  touch "$dest/.unpacked"
fi
echo "$dest/data/meshes"
