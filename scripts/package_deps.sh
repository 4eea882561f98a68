#!/usr/bin/env bash
# Fetches and builds what the portable package links (scripts/package.sh calls it): static,
# position-independent libraries and the headers of every Python the package targets, all cached
# under $DGMESH_CACHE (default /var/cache/dgmesh), never in the repository. A second run finds
# everything there and does nothing. Prints the prefix the libraries went to.
#
#   $CACHE/apt/SUITE/      private apt state per Debian suite (the host's /etc/apt is not touched)
#   $CACHE/debs/SUITE/     downloaded .debs, each unpacked (dpkg-deb -x) into $CACHE/debs/SUITE/x/NAME
#   $CACHE/src/            Debian source packages of bookworm (apt-get source)
#   $CACHE/static/         the prefix: lib/*.a (PIC), include/, lib/libgomp.so.1
set -euo pipefail
cache=${DGMESH_CACHE:-/var/cache/dgmesh}
prefix=$cache/static
jobs=$(nproc)
log() { printf '[package-deps] %s\n' "$*" >&2; }

# Host tools: dpkg-source (dpkg-dev) unpacks source packages, patchelf renames libgomp.
need=()
for p in dpkg-dev patchelf cmake g++ make; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if ((${#need[@]})); then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >&2
fi

# The Debian mirror this machine already uses (the bookworm main index's site), else debootstrap's.
mirror=$(apt-get indextargets --format '$(URI)' 'Release: bookworm' 'Component: main' 2>/dev/null |
  sed -n 's#/dists/.*##p' | head -n 1)
mirror=${mirror:-http://deb.debian.org/debian}

# apt_private SUITE [TYPES]: a private apt (own sources.list, state and cache under $cache/apt/SUITE[-src])
# whose lists are fetched once; prints the apt-get options that select it.
apt_private() {
  local suite=$1 types=${2:-deb} d=$cache/apt/$1${2:+-src}
  local opts="-o Dir::Etc::SourceList=$d/sources.list -o Dir::Etc::SourceParts=/dev/null
    -o Dir::State=$d/state -o Dir::Cache=$d/cache -o Acquire::Check-Valid-Until=false
    -o APT::Sandbox::User=root -o Debug::NoLocking=1"
  if [ ! -f "$d/.updated" ]; then
    mkdir -p "$d/state/lists/partial" "$d/cache/archives/partial"
    : >"$d/sources.list"
    for t in $types; do
      echo "$t [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] $mirror $suite main" >>"$d/sources.list"
    done
    : >"$d/state/status"
    # shellcheck disable=SC2086
    apt-get $opts update -qq >&2
    touch "$d/.updated"
  fi
  echo "$opts"
}

# deb_unpack SUITE PKG...: downloads each package of SUITE and unpacks it into $cache/debs/SUITE/x/PKG.
deb_unpack() {
  local suite=$1; shift
  local d=$cache/debs/$suite opts p
  opts=$(apt_private "$suite")
  mkdir -p "$d"
  for p in "$@"; do
    [ -d "$d/x/$p" ] && continue
    log "downloading $p ($suite)"
    # shellcheck disable=SC2086
    (cd "$d" && apt-get $opts download -qq "$p" >&2)
    mkdir -p "$d/x/$p.tmp"
    dpkg-deb -x "$(ls -t "$d/${p}"_*.deb | head -n 1)" "$d/x/$p.tmp"
    mv "$d/x/$p.tmp" "$d/x/$p"
  done
}

# src_unpack PKG: bookworm's source package PKG, unpacked (Debian patches applied) into $cache/src/PKG.
src_unpack() {
  local p=$1 s=$cache/src opts
  [ -d "$s/$p" ] && return 0
  opts=$(apt_private bookworm "deb deb-src")
  log "downloading the source of $p (bookworm)"
  rm -rf "$s/$p.tmp" && mkdir -p "$s/$p.tmp"
  # shellcheck disable=SC2086
  (cd "$s/$p.tmp" && apt-get $opts source -qq --download-only "$p" >&2 &&
    dpkg-source -x ./*.dsc tree >/dev/null 2>&1)
  mv "$s/$p.tmp/tree" "$s/$p" && rm -rf "$s/$p.tmp"
}

# --- headers: Python 3.13 (trixie), 3.14 (sid), pybind11 2.13 (trixie); 3.11 is the host's ----
deb_unpack trixie libpython3.13-dev pybind11-dev
deb_unpack sid libpython3.14-dev
# OpenBLAS: bookworm's static archive is position-independent (its shared library is linked from
# the same objects); its BLAS and the LAPACK routines CHOLMOD calls (potrf) are C, no Fortran runtime.
deb_unpack bookworm libopenblas-pthread-dev

mkdir -p "$prefix/lib" "$prefix/include"
ob=$cache/debs/bookworm/x/libopenblas-pthread-dev/usr/lib/x86_64-linux-gnu/openblas-pthread
[ -f "$prefix/lib/libopenblas.a" ] || cp "$(readlink -f "$ob/libopenblas.a")" "$prefix/lib/libopenblas.a"

# --- libgomp: GCC's libgomp.a is not PIC (local-exec TLS), so the shared one ships renamed ---------
# (libgomp-dgmesh.so.1, found through $ORIGIN). Where Blender already loaded a libgomp, the
# module's GOMP_*/omp_* calls bind to that one (same ABI); elsewhere to ours.
if [ ! -f "$prefix/lib/libgomp-dgmesh.so.1" ]; then
  cp "$(gcc -print-file-name=libgomp.so.1)" "$prefix/lib/libgomp-dgmesh.so.1.tmp"
  patchelf --set-soname libgomp-dgmesh.so.1 "$prefix/lib/libgomp-dgmesh.so.1.tmp"
  mv "$prefix/lib/libgomp-dgmesh.so.1.tmp" "$prefix/lib/libgomp-dgmesh.so.1"
fi

# --- Qhull (libqhull_r), PIC static --------------------------------------------------------------
if [ ! -f "$prefix/lib/libqhullstatic_r.a" ]; then
  src_unpack qhull
  log "building qhull (static, PIC)"
  b=$cache/build/qhull && rm -rf "$b"
  cmake -S "$cache/src/qhull" -B "$b" -DCMAKE_BUILD_TYPE=Release -DCMAKE_POSITION_INDEPENDENT_CODE=ON \
    -DCMAKE_C_FLAGS=-fvisibility=hidden -DBUILD_SHARED_LIBS=OFF -DBUILD_APPLICATIONS=OFF >/dev/null
  cmake --build "$b" -j"$jobs" --target qhullstatic_r >/dev/null
  mkdir -p "$prefix/include/libqhull_r"
  cp "$cache/src/qhull/src/libqhull_r/"*.h "$prefix/include/libqhull_r/"
  cp "$b/libqhullstatic_r.a" "$prefix/lib/"
fi

# --- SuiteSparse: only UMFPACK, CHOLMOD and what they need, PIC static, no METIS, no OpenMP -------
# (CHOLMOD's Partition module is the METIS one: -DNPARTITION leaves it out; orderings are AMD/COLAMD.)
ss_libs=(SuiteSparse_config AMD CAMD COLAMD CCOLAMD CHOLMOD UMFPACK)
if [ ! -f "$prefix/lib/libumfpack.a" ]; then
  src_unpack suitesparse
  log "building SuiteSparse ${ss_libs[*]} (static, PIC)"
  s=$cache/src/suitesparse
  for l in "${ss_libs[@]}"; do
    dir=$s/$l/Lib; [ "$l" = SuiteSparse_config ] && dir=$s/$l
    make -C "$dir" -j"$jobs" static CUDA=no CFOPENMP= CHOLMOD_CONFIG=-DNPARTITION \
      CF="-O3 -fPIC -fvisibility=hidden -fexceptions" >/dev/null
    cp "$dir"/lib*.a "$prefix/lib/"
    if [ "$l" = SuiteSparse_config ]; then cp "$dir"/*.h "$prefix/include/"; else cp "$s/$l/Include/"*.h "$prefix/include/"; fi
  done
fi

# --- OpenSubdiv: the CPU library only, PIC static, without OpenMP/TBB/GPU back ends --------------
if [ ! -f "$prefix/lib/libosdCPU.a" ]; then
  src_unpack opensubdiv
  log "building OpenSubdiv's CPU library (static, PIC)"
  b=$cache/build/opensubdiv   # kept: a run that stopped half-way resumes
  cmake -S "$cache/src/opensubdiv" -B "$b" -DCMAKE_BUILD_TYPE=Release -DCMAKE_POSITION_INDEPENDENT_CODE=ON \
    -DCMAKE_CXX_FLAGS="-fvisibility=hidden -fvisibility-inlines-hidden" \
    -DNO_EXAMPLES=ON -DNO_TUTORIALS=ON -DNO_REGRESSION=ON -DNO_PTEX=ON -DNO_DOC=ON -DNO_OMP=ON \
    -DNO_TBB=ON -DNO_CUDA=ON -DNO_OPENCL=ON -DNO_CLEW=ON -DNO_OPENGL=ON -DNO_METAL=ON -DNO_DX=ON \
    -DNO_TESTS=ON -DNO_GLTESTS=ON -DNO_GLEW=ON -DNO_GLFW=ON >/dev/null
  cmake --build "$b" -j"$jobs" --target osd_static_cpu >/dev/null
  (cd "$cache/src/opensubdiv" && find opensubdiv -name '*.h' -exec cp --parents {} "$prefix/include" \;)
  cp "$(find "$b" -name libosdCPU.a | head -n 1)" "$prefix/lib/"
fi
echo "$prefix"
